"""Cases with two or three library effects missing at once, from the truth's own case builder.

    python -m tests.diagnose.truth.combinations --out combos.json [--size 2] [--seeds 2]
        [--first-seed 0] [--classes steps ramp ...] [--limit N]

Each effect's strength is the one its single-effect case calibrates to `evident` (3 to 5
times the sensor noise, cases.build) on the same excitation class, seed, family and rate;
the truth carries all of them at once, on the plan, sensor and nominal of the first effect's
case (its excitation drawn from that case's seed), with the valve effect a lab would know
(cases.known_effects) kept only where neither valve effect is among the missing. A
combination counts only where every single-effect case is observable. diagnose is right when
it names every missing effect (the order and any extra name aside, which are reported).
"""

from __future__ import annotations

import argparse
import dataclasses
import itertools
import json
import math
import tempfile
import time
from pathlib import Path

import numpy as np

from tests.diagnose.truth import cases as cs
from tests.diagnose.truth import excitation as ex
from tests.diagnose.truth.battery import diagnose_cli
from tests.diagnose.truth.plant import FAMILIES, Truth
from tests.diagnose.truth.sensor import Sensor

VALVE = ("valve_lag", "dead_time")


def merged_truth(family_name: str, singles: list[cs.Case]) -> Truth:
    """One truth with every single case's extra physics (each field its case changed)."""
    base = Truth(FAMILIES[family_name])
    changes: dict[str, float | str] = {}
    for case in singles:
        for f in dataclasses.fields(Truth):
            value = getattr(case.truth, f.name)
            if f.name != "family" and value != getattr(base, f.name):
                changes.setdefault(f.name, value)
    effects = {c.spec.effect for c in singles}
    if set(VALVE) <= effects:
        changes["valve_tau_s"] = next(c.truth.valve_tau_s for c in singles if c.spec.effect == "valve_lag")
        changes["valve_rate_kpa_s"] = next(c.truth.valve_rate_kpa_s for c in singles
                                           if c.spec.effect == "valve_lag")
        changes["delay_s"] = next(c.truth.delay_s for c in singles if c.spec.effect == "dead_time")
    return dataclasses.replace(base, **changes)


def build(effects: tuple[str, ...], excitation: str, seed: int) -> cs.Case | None:
    """The case with every effect in `effects` missing from the nominal; None where one of the
    single-effect cases is not observable (or its generator fails)."""
    first = cs.CaseSpec(effects[0], excitation, seed, "evident").resolved()
    singles = []
    for effect in effects:
        spec = cs.CaseSpec(effect, excitation, seed, "evident", first.family, first.rate_hz)
        case = cs.build(spec)
        if not case.observable:
            return None
        singles.append(case)
    truth = merged_truth(first.family, singles)
    lead = singles[0]
    family = FAMILIES[first.family]
    known = {name: params for c in singles for name, params in c.nominal_effects.items()
             if name not in effects}
    tau0 = known.get("valve_lag", {}).get("tau_s", 0.0)
    delay0 = known.get("dead_time", {}).get("delay_s", 0.0)
    factors = [float(x) for x in cs._rng(first, "nominal").uniform(0.9, 1.1, 3)]
    nominal = cs.LinearModel(family.inertia_kgm2,
                             (family.damping_nms_per_rad + cs.linear_damping(truth)) * factors[0],
                             family.stiffness_nm_per_rad * factors[1], family.gain_nm_per_kpa * factors[2],
                             tau0, delay0)
    sensor: Sensor = lead.sensor
    plan: ex.Plan = lead.plan
    additive = sensor.additive(cs._rng(first, "noise"), plan.n, plan.rate_hz)
    traj, measured = cs._run(truth, plan, sensor, additive)
    start = cs.plain_finger(family, truth, tau0, delay0)
    visibility = cs._visibility(traj, plan, start, sensor)
    return cs.Case(first, truth, nominal, known, sensor, plan, traj, measured, math.nan, visibility, True,
                   "+".join(effects))


def combos(size: int, seeds: int, classes: tuple[str, ...],
           first_seed: int = 0) -> list[tuple[tuple[str, ...], str, int]]:
    groups = list(itertools.combinations(cs.LIBRARY, size))
    out = []
    for seed in range(first_seed, first_seed + seeds):
        for i, group in enumerate(groups):
            out.append((group, classes[(i + seed) % len(classes)], seed))
    return out


def run(effects: tuple[str, ...], excitation: str, seed: int, folder: Path) -> dict:
    where = folder / f"{'+'.join(effects)}-{excitation}-s{seed}"
    where.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    case = build(effects, excitation, seed)
    if case is None:
        return {"effects": list(effects), "excitation": excitation, "seed": seed, "observable": False}
    rec, model = cs.write(case, where)
    result, seconds, stderr = diagnose_cli(rec, model, where / "diagnose.json")
    named = [e.get("name") for e in result.get("effects") or []]
    partial = [e.get("name") for e in result.get("partial_effects") or []]
    return {"effects": list(effects), "excitation": excitation, "seed": seed, "observable": True,
            "family": case.spec.family, "rate_hz": case.rate_hz, "visibility": case.visibility,
            "verdict": result.get("verdict"), "named": named, "partial": partial,
            "all_named": set(effects) <= set(named), "generate_s": time.perf_counter() - t0 - seconds,
            "diagnose_s": seconds, "stderr": stderr[-300:] if not named else ""}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m tests.diagnose.truth.combinations", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", required=True, type=Path)
    ap.add_argument("--size", type=int, default=2, choices=(2, 3))
    ap.add_argument("--seeds", type=int, default=1)
    ap.add_argument("--first-seed", type=int, default=0, help="the first seed run (--seeds counts from it)")
    ap.add_argument("--classes", nargs="+", default=["steps", "prbs", "ramp", "multisine"],
                    choices=ex.CLASSES)
    ap.add_argument("--limit", type=int, default=0, help="at most this many combinations (0: all)")
    ap.add_argument("--folder", type=Path, default=Path(tempfile.gettempdir()) / "hand-truth-combinations")
    args = ap.parse_args(argv)
    todo = combos(args.size, args.seeds, tuple(args.classes), args.first_seed)
    if args.limit:
        todo = [todo[i] for i in np.linspace(0, len(todo) - 1, args.limit).round().astype(int)]
    rows = []
    for effects, excitation, seed in todo:
        row = run(effects, excitation, seed, args.folder)
        rows.append(row)
        print(json.dumps({k: row.get(k) for k in ("effects", "excitation", "verdict", "named", "all_named",
                                                   "diagnose_s")}), flush=True)
        args.out.write_text(json.dumps(rows, indent=1))
    counted = [r for r in rows if r["observable"]]
    hits = sum(r["all_named"] for r in counted)
    print(f"all {args.size} named in {hits} of {len(counted)} observable combinations "
          f"({len(rows) - len(counted)} left out: a single effect unobservable)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
