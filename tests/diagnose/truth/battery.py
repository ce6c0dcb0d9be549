"""The independent battery: recordings a lab would make of fingers whose physics the
project's simulator did not write, run through `hand-service diagnose`, scored.

    python -m tests.diagnose.truth.battery --out results.json [--jobs 1] [--seeds 3]
        [--effects NAME ...] [--classes NAME ...] [--noise-model ar|white] [--cache DIR]

Cases: every library effect × 6 excitation classes × 3 seeds × {concealed, evident} (the six
classes a window that moves with the seed, so each effect meets all ten over its three
seeds; `--classes-per-effect 10` runs every class for every seed); clean fingers (k, B, N of
the nominal off by up to 10 %, correlated noise and drift) on every class × 2 seeds;
hysteresis, contact and a pressure-dependent damping (outside the eight; the last in no
library form) on the same windows (the free release left out) × 2 seeds × {concealed,
evident}. The family (ringing, over-damped, stiff) and the
sample rate (100, 200, 500, 1000 Hz) rotate with the case. Recordings are cached by case
and by the generator's source (a change of the generator makes new ones); diagnose is run
afresh every time, as a subprocess of this Python, one BLAS thread each.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import hashlib  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from concurrent.futures import ProcessPoolExecutor  # noqa: E402
from pathlib import Path  # noqa: E402

from hand_service.commands.progress import Progress  # noqa: E402
from tests.diagnose.truth import cases as cs  # noqa: E402
from tests.diagnose.truth import observability, report, scoring  # noqa: E402
from tests.diagnose.truth.excitation import CLASSES  # noqa: E402

NEUTRAL = {"stiffness_ratio": 1.0}
# what labels the observability of a case beyond the eight (observability.labelled); a case
# cached under an earlier rule (without the recording's test, recorded.py) is labelled again
LABELLED_BY = "observability.observable, eight_left, recorded.parted"


def source_hash() -> str:
    here = Path(__file__).parent
    h = hashlib.sha256()
    for name in ("plant.py", "sensor.py", "excitation.py", "linear.py", "distinct.py", "calibration.py",
                 "cases.py", "files.py", "observability.py", "library_form.py", "recorded.py"):
        h.update((here / name).read_bytes())
    return h.hexdigest()[:12]


def engine_fingerprint() -> dict:
    """Which diagnose ran: the checkout's HEAD and a hash of the engine's files as they are (the
    work tree may hold changes not yet committed)."""
    root = Path(__file__).resolve().parents[3]
    try:
        head = subprocess.run(
            ["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True, text=True, check=False
        ).stdout.strip()
    except OSError:
        head = ""
    h = hashlib.sha256()
    files = sorted((root / "hand_service" / "diagnose").rglob("*.py")) + sorted(
        (root / "rtcore").glob("*.so")
    )
    files += [root / "hand_service" / "config" / "effects.py"]
    for f in files:
        if f.exists():
            h.update(f.read_bytes())
    return {"git_head": head, "engine_files_sha256": h.hexdigest()[:16]}


def default_cache() -> Path:
    return Path(tempfile.gettempdir()) / f"hand-truth-{source_hash()}"


def classes_for(effect: str, seed: int, per_effect: int, classes: tuple[str, ...]) -> list[str]:
    """`per_effect` of the classes, a window that moves by 4 with the seed (and by one with the
    effect), so three seeds of six cover all ten classes for every effect."""
    if per_effect >= len(classes):
        return list(classes)
    shift = 4 * seed + (*cs.ALL_EFFECTS, *cs.ON_REQUEST).index(effect)
    return [classes[(j + shift) % len(classes)] for j in range(per_effect)]


def specs(
    seeds: int = 3,
    effects: tuple[str, ...] | None = None,
    classes: tuple[str, ...] | None = None,
    ool_seeds: int = 2,
    per_effect: int = 6,
    clean_seeds: int = 2,
) -> list[cs.CaseSpec]:
    effects = effects or cs.ALL_EFFECTS
    classes = classes or CLASSES
    out: list[cs.CaseSpec] = []
    for effect in effects:
        if effect == cs.CLEAN:
            out += [cs.CaseSpec(effect, cls, seed, "none") for seed in range(clean_seeds) for cls in classes]
            continue
        outside = effect in cs.OUT_OF_LIBRARY or effect in cs.ON_REQUEST
        for seed in range(ool_seeds if outside else seeds):
            for cls in classes_for(effect, seed, per_effect, classes):
                if outside and cls == "free_release":
                    continue  # a finger let go already in contact is not a free release
                out += [cs.CaseSpec(effect, cls, seed, mag) for mag in ("concealed", "evident")]
    # seed by seed, so that a run cut short has every effect and class
    return sorted(out, key=lambda s: (s.seed, s.magnitude != "concealed", CLASSES.index(s.excitation)))


def diagnose_argv(recording: Path, model: Path, out: Path, noise_model: str = "ar",
                  search: tuple[str, ...] = ()) -> list[str]:
    """The arguments of `hand-service diagnose` for one case: its JSON to `out`, quiet;
    `search`: effects searched for beyond the default (`--search`)."""
    return ["diagnose", str(recording), "--model", str(model), "--json", str(out), "--quiet",
            "--noise-model", noise_model, *[arg for name in search for arg in ("--search", name)]]


def diagnose_in_process(recording: Path, model: Path, folder: Path) -> dict:
    """`hand-service diagnose` on one case in this process (for tests): its JSON, the command
    checked to have exited 0."""
    from hand_service.cli import main

    out = folder / "diagnose.json"
    code = main(diagnose_argv(recording, model, out))
    assert code == 0, f"diagnose exited {code}"
    return json.loads(out.read_text())


def diagnose_cli(
    recording: Path, model: Path, out: Path, noise_model: str = "ar", timeout_s: float = 600.0,
    search: tuple[str, ...] = ()
) -> tuple[dict, float, str]:
    """Runs `hand-service diagnose` as a subprocess; (its JSON, seconds, stderr)."""
    argv = diagnose_argv(recording, model, out, noise_model, search)
    cmd = [sys.executable, "-m", "hand_service.cli", *argv]
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
    t0 = time.perf_counter()
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout_s, env=env, check=False)
    except subprocess.TimeoutExpired:
        return {"verdict": "timeout"}, time.perf_counter() - t0, "timeout"
    seconds = time.perf_counter() - t0
    if proc.returncode != 0 or not out.exists():
        return {"verdict": f"exit {proc.returncode}"}, seconds, proc.stderr.strip()[-400:]
    return json.loads(out.read_text()), seconds, proc.stderr.strip()[-400:]


def generate(spec: cs.CaseSpec, folder: Path) -> tuple[Path, Path, dict, float]:
    """The case's files, from the cache when it has them; (recording, model, summary, seconds)."""
    sid = spec.id
    rec, model, meta = folder / f"{sid}.csv", folder / f"{sid}.yaml", folder / f"{sid}.truth.json"
    t0 = time.perf_counter()
    if rec.exists() and model.exists() and meta.exists():
        summary = json.loads(meta.read_text())
        # a case of an effect beyond the eight cached before observability.py labelled it is made again
        if summary["effect"] not in observability.BEYOND_EIGHT or summary.get("labelled_by") == LABELLED_BY:
            return rec, model, summary, 0.0
    cs.write(observability.labelled(cs.build(spec)), folder)
    summary = json.loads(meta.read_text())
    if summary["effect"] in observability.BEYOND_EIGHT:
        summary["labelled_by"] = LABELLED_BY
        meta.write_text(json.dumps(summary, indent=1))
    return rec, model, summary, time.perf_counter() - t0


def param_error(summary: dict, result: dict) -> float | None:
    """|estimate − truth| / |truth − neutral| of the named effect's parameter, in the library's terms."""
    eq = summary.get("library_equivalent") or {}
    effects = result.get("effects") or []
    if not eq or not effects or effects[0].get("name") != summary["effect"]:
        return None
    ((param, true),) = eq.items()
    est = (effects[0].get("params") or {}).get(param)
    if est is None:
        return None
    neutral = NEUTRAL.get(param, 0.0)
    return abs(est - true) / abs(true - neutral) if true != neutral else None


def run_case(spec: cs.CaseSpec, folder: str, noise_model: str, timeout_s: float = 600.0,
             search: tuple[str, ...] = ()) -> dict:
    folder_p = Path(folder)
    try:
        rec, model, summary, gen_s = generate(spec, folder_p)
    except Exception as exc:  # a generator bug must not stop the battery: it is reported
        r = spec.resolved()
        return {
            "id": r.id,
            "effect": r.effect,
            "excitation": r.excitation,
            "seed": r.seed,
            "magnitude": r.magnitude,
            "family": r.family,
            "rate_hz": r.rate_hz,
            "visibility": math.nan,
            "observable": False,
            "verdict": "generator_error",
            "named": [],
            "outcome": "generator_error",
            "right": False,
            "on_target": None,
            "generate_s": 0.0,
            "diagnose_s": 0.0,
            "param_error": None,
            "stderr": repr(exc),
        }
    out = folder_p / f"{spec.id}.{noise_model}.diagnose.json"
    out.unlink(missing_ok=True)
    engine = engine_fingerprint()["engine_files_sha256"]
    result, diag_s, stderr = diagnose_cli(rec, model, out, noise_model, timeout_s, search)
    scored = scoring.score(spec, summary["observable"], result)
    on_target = None
    if summary["magnitude"] in cs.ACCEPT:
        lo, hi = cs.ACCEPT[summary["magnitude"]]
        on_target = lo <= summary["visibility"] <= hi
    return {
        **summary,
        **scored,
        "on_target": on_target,
        "engine": engine,
        "finished": time.strftime("%H:%M:%S"),
        "generate_s": gen_s,
        "diagnose_s": diag_s,
        "diagnose_seconds_reported": result.get("seconds"),
        "param_error": param_error(summary, result),
        "grade": result.get("grade"),
        "params": (result.get("effects") or [{}])[0].get("params"),
        "partial_effects": [e.get("name") for e in result.get("partial_effects") or []],
        "warnings": result.get("warnings"),
        "stderr": stderr
        if scored["verdict"]
        not in ("consistent", "parameters_only", "missing_physics", "unexplained", "insufficient_excitation")
        else "",
        "files": {"recording": str(rec), "model": str(model)},
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="python -m tests.diagnose.truth.battery",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("--out", type=Path, required=True, help="results JSON (with --table: one to print)")
    ap.add_argument("--table", action="store_true", help="print the tables of an existing --out and stop")
    ap.add_argument(
        "--jobs", type=int, default=1, help="cases run at once (default 1: the machine is shared)"
    )
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--ool-seeds", type=int, default=2)
    ap.add_argument("--clean-seeds", type=int, default=2, help="clean cases: every class × this many seeds")
    ap.add_argument(
        "--classes-per-effect",
        type=int,
        default=6,
        help="classes per effect and seed, a window moving with the seed (10: every class)",
    )
    ap.add_argument("--effects", nargs="*", choices=(*cs.ALL_EFFECTS, *cs.ON_REQUEST),
                    help="the battery's effects (default: all but the on-request ones, which, not "
                         "searched here, are then cases outside the searched library)")
    ap.add_argument("--classes", nargs="*", choices=CLASSES)
    ap.add_argument("--noise-model", choices=("ar", "white"), default="ar")
    ap.add_argument("--search", nargs="*", default=[], help="effects diagnose searches beyond its default")
    ap.add_argument(
        "--cache",
        type=Path,
        default=None,
        help="where recordings are kept (default: a folder in /tmp named after the generator's source)",
    )
    ap.add_argument("--magnitudes", nargs="*", choices=("concealed", "evident"),
                    help="only the effects' cases of these magnitudes (default both; clean cases stay)")
    ap.add_argument("--limit", type=int, default=0, help="run only the first N cases")
    ap.add_argument(
        "--timeout", type=float, default=600.0, help="seconds one diagnose may take (then: timeout)"
    )
    ap.add_argument(
        "--quiet",
        action="store_true",
        help="no progress on stderr (else a bar on a terminal, a line every few seconds elsewhere); "
        "the line of each case still goes to stdout",
    )
    args = ap.parse_args(argv)
    if args.table:
        print(report.render(report.tables(json.loads(args.out.read_text())["cases"])))
        return 0
    folder = args.cache or default_cache()
    folder.mkdir(parents=True, exist_ok=True)
    todo = specs(
        args.seeds,
        tuple(args.effects) if args.effects else None,
        tuple(args.classes) if args.classes else None,
        args.ool_seeds,
        args.classes_per_effect,
        args.clean_seeds,
    )
    if args.magnitudes:
        todo = [s for s in todo if s.effect == cs.CLEAN or s.magnitude in args.magnitudes]
    if args.limit:
        todo = todo[: args.limit]
    print(
        f"{len(todo)} cases, recordings in {folder}, noise model {args.noise_model}, {args.jobs} job(s)",
        flush=True,
    )
    t0 = time.perf_counter()
    rows: list[dict] = []
    engine = engine_fingerprint()

    def save(final: bool) -> None:
        args.out.write_text(
            json.dumps(
                {
                    "settings": {
                        "seeds": args.seeds,
                        "ool_seeds": args.ool_seeds,
                        "noise_model": args.noise_model,
                        "jobs": args.jobs,
                        "cases": len(rows),
                        "of": len(todo),
                        "complete": final,
                        "generator": source_hash(),
                        "wall_s": time.perf_counter() - t0,
                        "recordings": str(folder),
                        "engine_at_start": engine,
                        "engine_at_save": engine_fingerprint(),
                    },
                    "tables": report.tables(rows),
                    "cases": rows,
                },
                indent=1,
                default=str,
            )
        )

    progress = Progress("battery", total=len(todo), quiet=args.quiet)

    def note(row: dict) -> None:
        rows.append(row)
        if len(rows) % 10 == 0:
            save(False)
        mark = "ok " if row["right"] else "BAD"
        progress.write(
            f"[{len(rows):4d}/{len(todo)}] {mark} {row['id']:62s} v={row['visibility']:5.2f} "
            f"{'obs' if row['observable'] else 'unobs'} -> {row['verdict']} {row['named'][:2]} "
            f"({row['generate_s']:.1f}+{row['diagnose_s']:.1f} s)"
        )
        progress.advance(message=f"{row['id']} -> {row['verdict']}")

    with progress:
        if args.jobs <= 1:
            for spec in todo:
                progress.say(f"running {spec.id}")
                note(run_case(spec, str(folder), args.noise_model, args.timeout, tuple(args.search)))
        else:
            with ProcessPoolExecutor(max_workers=args.jobs) as pool:
                futures = [
                    pool.submit(run_case, spec, str(folder), args.noise_model, args.timeout,
                                tuple(args.search))
                    for spec in todo
                ]
                for fut in futures:
                    note(fut.result())
        progress.done()
    save(True)
    print(report.render(report.tables(rows)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
