"""Run `diagnose` on every real-rig fixture and tabulate its answers against the written
expectations (README.md §1 and §6).

    python -m tests.diagnose.real.table --out X.json [--only RIG ...] [--native-only] [--jobs 1]

Each fixture is run at its own rate and, where the rate allows (200 Hz or more, and the
motion slow enough not to alias: `lower_rate`), resampled to 100 Hz (rate invariance,
issue 44): the angle read at the new instants (linear between samples), the command held
over each sample averaged exactly over each new period (the right input for a command held
over the sample period) or, for a command read linear between samples (`--input-hold
point`), read at the new instants like the angle.

A row is a **confident wrong verdict** when a library effect outside the rig's
`acceptable_effects` is named with grade `complete` or `dominant`; a **negative control
failed** when a negative control is not `unexplained` or `insufficient_excitation`.
"""

from __future__ import annotations

import argparse
import json
import math
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from hand_service.cli import main as cli_main
from hand_service.config.effects import LIBRARY
from hand_service.config.profile import load_model
from tests.diagnose.real.odefit import Recording, read_csv, write_csv
from tests.diagnose.real.rawcheck import raw_rms
from tests.diagnose.real.rigs import RIGS

HERE = Path(__file__).resolve().parent
FIXTURES: tuple[str, ...] = ("silverbox", "emps", *(rig.name for rig in RIGS))
LIBRARY_EFFECTS = frozenset(spec.name for spec in LIBRARY)
CONFIDENT_GRADES = ("complete", "dominant")
DECIMATE_FROM_HZ = 200.0
TARGET_HZ = 100.0
ALIAS_SHARE = 0.01


@dataclass(frozen=True)
class Expectation:
    kind: str
    effect: str | None
    acceptable_effects: tuple[str, ...]
    acceptable_verdicts: tuple[str, ...]
    control: str | None


def expected_json(rig: str) -> dict[str, Any]:
    return json.loads((HERE / f"{rig}_expected.json").read_text())


def expectation(rig: str) -> Expectation:
    """The written expectation; Silverbox's and EMPS's from §1 (one documented effect; for
    EMPS, whose axis has no spring, `insufficient_excitation` is honest too)."""
    exp = expected_json(rig)
    if "kind" not in exp:
        verdicts = ("missing_physics", "insufficient_excitation") if rig == "emps" else ("missing_physics",)
        return Expectation("missing_physics", exp["effect"], (exp["effect"],), verdicts, None)
    return Expectation(exp["kind"], exp["effect"], tuple(exp["acceptable_effects"]),
                       tuple(exp["acceptable_verdicts"]), exp["control"])


@dataclass(frozen=True)
class Judgement:
    verdict_ok: bool
    confident_wrong: bool
    control_failed: bool
    wrong_effects: tuple[str, ...]


def judge(exp: Expectation, result: dict[str, Any]) -> Judgement:
    named = tuple(str(e["name"]) for e in result.get("effects") or [])
    wrong = tuple(name for name in named if name not in exp.acceptable_effects)
    confident = result.get("grade") in CONFIDENT_GRADES and bool(wrong)
    control_failed = exp.kind == "negative_control" and result.get("verdict") not in (
        "unexplained", "insufficient_excitation")
    verdict_ok = result.get("verdict") in exp.acceptable_verdicts and not confident
    if exp.kind == "missing_physics" and result.get("verdict") == "missing_physics":
        verdict_ok = verdict_ok and bool(named) and named[0] in exp.acceptable_effects
    return Judgement(verdict_ok, confident, control_failed, wrong)


def rate_hz(rec: Recording) -> float:
    return 1.0 / rec.dt


def power_above(rec: Recording, freq_hz: float) -> float:
    """The share of the angle's varying power above freq_hz."""
    x = rec.theta_deg - np.mean(rec.theta_deg)
    power = np.abs(np.fft.rfft(x)) ** 2
    freqs = np.fft.rfftfreq(x.size, rec.dt)
    return float(power[freqs > freq_hz].sum() / max(power.sum(), 1e-300))


def lower_rate(rec: Recording) -> tuple[float | None, str]:
    """TARGET_HZ, or None and why not: a rate under 200 Hz, or motion 100 Hz would alias
    (ALIAS_SHARE or more of the angle's power above 0.4 times it)."""
    native = rate_hz(rec)
    if native < DECIMATE_FROM_HZ:
        return None, f"native {native:.4g} Hz"
    above = power_above(rec, 0.4 * TARGET_HZ)
    if above >= ALIAS_SHARE:
        return None, (f"{100 * above:.0f} % of the angle's power lies above {0.4 * TARGET_HZ:.3g} Hz: "
                      f"{TARGET_HZ:.4g} Hz would alias it")
    return TARGET_HZ, ""


def resample(rec: Recording, new_rate_hz: float, hold: str) -> Recording:
    """The recording at new_rate_hz (lower than its own): see the module's docstring."""
    period = 1.0 / new_rate_hz
    t = rec.t[0] + np.arange(int((rec.t[-1] - rec.t[0]) / period)) * period
    theta = np.interp(t, rec.t, rec.theta_deg)
    if hold == "point":
        return Recording(t - rec.t[0], np.interp(t, rec.t, rec.p), theta)
    edges = np.append(rec.t, rec.t[-1] + rec.dt)  # the held command's integral, exact
    integral = np.concatenate([[0.0], np.cumsum(rec.p * np.diff(edges))])
    area = np.interp(np.append(t, t[-1] + period), edges, integral)
    return Recording(t - rec.t[0], np.diff(area) / period, theta)


def run_diagnose(rig: str, new_rate_hz: float | None, workdir: Path) -> dict[str, Any]:
    """diagnose's JSON for the fixture (resampled to new_rate_hz when given), with the wall time."""
    hold = str(expected_json(rig).get("input_hold", "zoh"))
    csv = HERE / f"{rig}.csv"
    tag = "native" if new_rate_hz is None else f"{new_rate_hz:g}hz"
    if new_rate_hz is not None:
        small = resample(read_csv(csv), new_rate_hz, hold)
        csv = workdir / f"{rig}_{tag}.csv"
        write_csv(csv, small, {"source": f"{rig}.csv resampled to {new_rate_hz:g} Hz by "
                                         "tests/diagnose/real/table.py",
                               "sample_rate_hz": f"{rate_hz(small):.6g}"}, (".6f", ".6g", ".6g"))
    out = workdir / f"{rig}_{tag}.json"
    started = time.perf_counter()
    code = cli_main(["diagnose", str(csv), "--model", str(HERE / f"{rig}_model.yaml"),
                     "--input-hold", hold, "--json", str(out), "--quiet"])
    wall_s = time.perf_counter() - started
    if code != 0 or not out.exists():
        return {"verdict": f"exit {code}", "grade": None, "effects": [], "wall_s": wall_s}
    result: dict[str, Any] = json.loads(out.read_text())
    result["wall_s"] = wall_s
    return result


def _fmt(value: object) -> str:
    return f"{value:.3g}" if isinstance(value, float) else "-"


def _raw_rms(result: dict[str, Any]) -> str:
    """Raw RMS before/after when diagnose's JSON carries it (issue 44 asks for it)."""
    for key in ("raw_rmse_deg", "rmse_raw_deg", "raw_rms_deg"):
        raw = result.get(key)
        if isinstance(raw, dict):
            return " / ".join(_fmt(raw.get(k)) for k in ("nominal", "refit", "augmented"))
    return "n/a"


def our_raw_rms(rig: str, new_rate_hz: float | None, result: dict[str, Any]) -> dict[str, float | None]:
    """rawcheck's raw RMS of the nominal model and of diagnose's refit with its effects."""
    rec = read_csv(HERE / f"{rig}.csv")
    hold = str(expected_json(rig).get("input_hold", "zoh"))
    if new_rate_hz is not None:
        rec = resample(rec, new_rate_hz, hold)
    model = load_model(HERE / f"{rig}_model.yaml")
    nominal = {"inertia_kgm2": model.inertia_kgm2, "damping_nms_per_rad": model.damping_nms_per_rad,
               "stiffness_nm_per_rad": model.stiffness_nm_per_rad,
               "pressure_gain_nm_per_kpa": model.pressure_gain_nm_per_kpa}
    return raw_rms(rec, nominal, result, hold)


def _heldout(result: dict[str, Any]) -> str:
    rmse = result.get("rmse_deg") or {}
    vals = [rmse.get(k) for k in ("refit", "augmented")]
    return " / ".join("-" if v is None or not math.isfinite(v) else f"{v:.3g}" for v in vals)


def _effects(result: dict[str, Any]) -> str:
    parts = []
    for e in result.get("effects") or []:
        params = e.get("params") or {}
        value = next(iter(params.values()), None)
        parts.append(f"{e['name']} {value:.3g}" if isinstance(value, float) else str(e["name"]))
    return ", ".join(parts) or "none"


def one_row(task: tuple[str, int | None]) -> dict[str, Any]:
    rig, new_rate_hz = task
    exp = expectation(rig)
    with tempfile.TemporaryDirectory() as tmp:
        result = run_diagnose(rig, new_rate_hz, Path(tmp))
    mark = judge(exp, result)
    ours = our_raw_rms(rig, new_rate_hz, result)
    rate = result.get("sample_rate_hz")
    return {"rig": rig, "resampled": new_rate_hz is not None, "rate_hz": rate,
            "expected": exp.effect or (f"{exp.kind} ({exp.control})" if exp.control else exp.kind),
            "verdict": result.get("verdict"), "grade": result.get("grade"),
            "effects": _effects(result), "raw_rms_deg": _raw_rms(result), "our_raw_rms_deg": ours,
            "heldout_rmse_deg": _heldout(result), "seconds": result.get("wall_s"),
            "judgement": asdict(mark), "warnings": result.get("warnings"),
            "partial_effects": [e.get("name") for e in result.get("partial_effects") or []]}


def markdown(rows: list[dict[str, Any]]) -> str:
    lines = ["| rig | rate (Hz) | expected | verdict (grade) | effects named | raw RMS nominal / refit / "
             "augmented, diagnose's (deg) | raw RMS nominal → refit with effects, rawcheck's (deg) | "
             "held-out RMSE refit / augmented (deg) | s | flag |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        j = r["judgement"]
        flag = ("CONFIDENT WRONG" if j["confident_wrong"] else "") + \
               (" CONTROL FAILED" if j["control_failed"] else "")
        flag = flag.strip() or ("ok" if j["verdict_ok"] else "not expected")
        rate = f"{r['rate_hz']:.4g}" if isinstance(r["rate_hz"], float) else "?"
        lines.append(f"| {r['rig']} | {rate} | {r['expected']} | {r['verdict']} ({r['grade'] or '-'}) | "
                     f"{r['effects']} | {r['raw_rms_deg']} | {_fmt(r['our_raw_rms_deg']['nominal'])} → "
                     f"{_fmt(r['our_raw_rms_deg']['augmented'])} | {r['heldout_rmse_deg']} | "
                     f"{r['seconds']:.1f} | {flag} |")
    wrong = sum(r["judgement"]["confident_wrong"] for r in rows)
    failed = sum(r["judgement"]["control_failed"] for r in rows)
    lines.append("")
    lines.append(f"{len(rows)} runs: {wrong} confident wrong verdicts, {failed} negative-control runs "
                 "not unexplained/insufficient_excitation.")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--only", nargs="*", choices=FIXTURES)
    parser.add_argument("--native-only", action="store_true")
    parser.add_argument("--jobs", type=int, default=1)
    args = parser.parse_args(argv)
    tasks: list[tuple[str, float | None]] = []
    not_decimated: dict[str, str] = {}
    for rig in args.only or FIXTURES:
        tasks.append((rig, None))
        lower, why = lower_rate(read_csv(HERE / f"{rig}.csv"))
        if lower is not None and not args.native_only:
            tasks.append((rig, lower))
        elif lower is None:
            not_decimated[rig] = why
    if args.jobs > 1:
        with ProcessPoolExecutor(args.jobs) as pool:
            rows = list(pool.map(one_row, tasks))
    else:
        rows = []
        for task in tasks:
            rows.append(one_row(task))
            print(f"{task[0]} at {task[1] or 'native'}: {rows[-1]['verdict']} ({rows[-1]['grade']}) "
                  f"{rows[-1]['effects']} {rows[-1]['seconds']:.1f} s", flush=True)
    table = markdown(rows) + "\n\nNot resampled: " + "; ".join(
        f"{rig} ({why})" for rig, why in not_decimated.items()) + "."
    args.out.write_text(json.dumps({"rows": rows, "markdown": table, "not_decimated": not_decimated,
                                    "rates_native_vs_decimated": _rate_pairs(rows)}, indent=2) + "\n")
    print(table)
    return 0


def _rate_pairs(rows: list[dict[str, Any]]) -> dict[str, bool]:
    """Per rig run at two rates: whether the verdict class is the same (rate invariance)."""
    by_rig: dict[str, list[str]] = {}
    for r in rows:
        by_rig.setdefault(r["rig"], []).append(str(r["verdict"]))
    return {rig: len(set(v)) == 1 for rig, v in by_rig.items() if len(v) > 1}


if __name__ == "__main__":
    np.seterr(all="ignore")
    raise SystemExit(main())
