"""The concealed-effect battery: every effect x excitations x seeds, plus clean recordings.

    python -m hand_service.diagnose.concealed.battery --json battery.json --markdown battery.md

For each case a finger of the default hand (cycling through the five), a sensor noise in
0.3-1.0 deg, a concealment ratio in 0.4-1.5 and a ±10 % perturbation of k, B, N are drawn
from the seed; the recording is 30 s at 100 Hz. The figures: top-1 naming rate per effect,
false positives on clean recordings, median parameter error, time per recording.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import zlib
from dataclasses import asdict, dataclass

import numpy as np

from hand_service.config import effects as fx
from hand_service.config.profile import load_profile
from hand_service.diagnose.concealed.generator import generate
from hand_service.diagnose.engine import diagnose
from hand_service.jsonio import plain, write_json

FINGERS = ("index", "middle", "ring", "little", "thumb")
SIGNED = ("cubic_stiffness", "gravity")  # effects that occur either way; the rest one way


@dataclass
class Case:
    effect: str  # "clean" for nothing hidden
    excitation: str
    seed: int
    finger: str
    noise_deg: float
    ratio_target: float
    true_value: float | None = None
    concealment: float = 0.0
    verdict: str = ""
    named: list[str] | None = None
    estimate: float | None = None
    parameter_error: float | None = None  # |estimate − true| / |true − neutral|
    rmse_refit_deg: float = 0.0
    rmse_augmented_deg: float = 0.0
    rmse_nominal_deg: float = 0.0
    seconds: float = 0.0

    @property
    def top1(self) -> bool:
        return bool(self.named) and self.named[0] == self.effect

    @property
    def false_positive(self) -> bool:
        return self.effect == "clean" and (bool(self.named) or self.verdict not in ("consistent",
                                                                                    "parameters_only"))


def draw(effect: str, excitation: str, seed: int) -> Case:
    rng = np.random.default_rng([seed, zlib.crc32(effect.encode()), zlib.crc32(excitation.encode())])
    ratio = float(rng.uniform(0.4, 1.5))
    if effect in SIGNED and seed % 2 == 1:
        ratio = -ratio
    return Case(effect, excitation, seed, FINGERS[seed % len(FINGERS)], float(rng.uniform(0.3, 1.0)), ratio)


def run_case(case: Case, duration_s: float = 30.0, rate_hz: float = 100.0) -> Case:
    model = load_profile(None).finger(case.finger).model
    hidden = {} if case.effect == "clean" else {case.effect: None}
    c = generate(model, hidden, case.excitation, duration_s, rate_hz, case.noise_deg, seed=case.seed,
                 conceal_ratio=case.ratio_target)
    case.concealment = c.concealment
    started = time.perf_counter()
    d = diagnose(c.nominal, c.t_s, c.pressure_kpa, c.angle_deg, rate_hz)
    case.seconds = time.perf_counter() - started
    case.verdict = d.verdict
    case.named = [e.name for e in d.effects]
    case.rmse_nominal_deg = d.rmse_deg["nominal"]
    case.rmse_refit_deg = d.rmse_deg["refit"]
    case.rmse_augmented_deg = d.rmse_deg["augmented"]
    if hidden:
        spec = fx.BY_NAME[case.effect]
        case.true_value = c.hidden[case.effect][spec.param]
        found = next((e for e in d.effects if e.name == case.effect), None)
        if found is not None:
            case.estimate = found.value
            case.parameter_error = abs(found.value - case.true_value) / abs(case.true_value - spec.neutral)
    return case


def plan(seeds: int, excitations: tuple[str, ...], clean_seeds: int) -> list[Case]:
    cases = [draw(spec.name, ex, seed) for spec in fx.SEARCHED for ex in excitations for seed in range(seeds)]
    cases += [draw("clean", ex, 100 + seed) for ex in excitations for seed in range(clean_seeds)]
    return cases


def summarise(cases: list[Case]) -> dict:
    per_effect = {}
    for spec in fx.SEARCHED:
        mine = [c for c in cases if c.effect == spec.name]
        if not mine:
            continue
        errors = [c.parameter_error for c in mine if c.parameter_error is not None and c.top1]
        per_effect[spec.name] = {
            "cases": len(mine), "top1_rate": float(np.mean([c.top1 for c in mine])),
            "median_parameter_error": float(np.median(errors)) if errors else None,
            "median_concealment": float(np.median([c.concealment for c in mine])),
            "wrong_names": sum(bool(c.named) and not c.top1 for c in mine),
        }
    hidden = [c for c in cases if c.effect != "clean"]
    clean = [c for c in cases if c.effect == "clean"]
    errors = [c.parameter_error for c in hidden if c.parameter_error is not None and c.top1]
    return {
        "per_effect": per_effect,
        "top1_rate": float(np.mean([c.top1 for c in hidden])) if hidden else None,
        "wrong_name_rate": float(np.mean([bool(c.named) and not c.top1 for c in hidden])) if hidden else None,
        "false_positive_rate": float(np.mean([c.false_positive for c in clean])) if clean else None,
        "clean_cases": len(clean),
        "median_parameter_error": float(np.median(errors)) if errors else None,
        "seconds_per_recording_median": float(np.median([c.seconds for c in cases])),
        "seconds_per_recording_max": float(np.max([c.seconds for c in cases])),
    }


def markdown(summary: dict, cases: list[Case]) -> str:
    lines = ["| effect | cases | top-1 named | wrong name | median parameter error | median concealment |",
             "|---|---|---|---|---|---|"]
    for name, s in summary["per_effect"].items():
        err = "–" if s["median_parameter_error"] is None else f"{100 * s['median_parameter_error']:.1f} %"
        lines.append(f"| {name} | {s['cases']} | {100 * s['top1_rate']:.0f} % | {s['wrong_names']} | {err} | "
                     f"{s['median_concealment']:.2f} |")
    clean = [c for c in cases if c.effect == "clean"]
    lines.append(f"| clean (no hidden effect) | {len(clean)} | false positives: "
                 f"{sum(c.false_positive for c in clean)} | | | |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--clean-seeds", type=int, default=6)
    parser.add_argument("--excitations", default="steps,sweep")
    parser.add_argument("--rate", type=float, default=100.0, help="sample rate in Hz (default 100)")
    parser.add_argument("--duration", type=float, default=30.0, help="seconds per recording (default 30)")
    parser.add_argument("--ratio", type=float, default=None,
                        help="concealment for every case instead of a draw in 0.4-1.5 "
                             "(the sign still alternates)")
    parser.add_argument("--noise", type=float, default=None, help="sensor noise (deg) instead of a draw")
    parser.add_argument("--json", default=None)
    parser.add_argument("--markdown", default=None)
    args = parser.parse_args(argv)
    cases = plan(args.seeds, tuple(args.excitations.split(",")), args.clean_seeds)
    for case in cases:
        if args.ratio is not None:
            case.ratio_target = float(np.copysign(args.ratio, case.ratio_target))
        if args.noise is not None:
            case.noise_deg = args.noise
    started = time.perf_counter()
    for i, case in enumerate(cases, start=1):
        run_case(case, args.duration, args.rate)
        mark = "ok" if (case.top1 if case.effect != "clean" else not case.false_positive) else "MISS"
        print(f"[{i:3d}/{len(cases)} {time.perf_counter() - started:6.0f} s] {case.effect:<21} "
              f"{case.excitation:<6} "
              f"seed {case.seed:<3} {case.finger:<6} conceal {case.concealment:4.2f} -> {case.verdict:<23} "
              f"{','.join(case.named or []) or '-':<24} err "
              f"{'-' if case.parameter_error is None else f'{100 * case.parameter_error:.0f}%':>5} "
              f"{case.seconds:4.1f} s {mark}", file=sys.stderr, flush=True)
    summary = summarise(cases)
    table = markdown(summary, cases)
    print(table)
    print(json.dumps(plain({k: v for k, v in summary.items() if k != "per_effect"}), indent=1))
    if args.json:
        write_json(args.json, {"summary": summary, "cases": [asdict(c) for c in cases]})
    if args.markdown:
        with open(args.markdown, "w") as handle:
            handle.write(table + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
