"""Which part of the mismatched plant moves the ordering: the pinch run on the mismatched
plant with each of its parts taken out in turn, everything else as `replicate --pinch
--pinch-plant mismatched` (the lab's measurement, the calibration again on each plant,
the tuning rule, the seed and the placements).

    python -m hand_service.pinch.ablation [--object chip] [--trials 50] [--rule operator] [--seed 1]
                                          [--release-s 0.25] [--full-only]

Prints one markdown table: per plant, force control's and constant pressure's pooled
success on the object, the paired difference with its 95 % interval and McNemar's exact
p, force control's failures and the force estimate's RMS error. --release-s sets how long
the person's hand takes to open (0: at once); --full-only runs the mismatched plant alone.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import tempfile
from pathlib import Path

from hand_service.pinch.experiment import run_pinch
from hand_service.pinch.mismatch import NONE, PAPER_MISMATCH, Mismatch, identify_on_plant
from hand_service.pinch.objects import OBJECTS
from hand_service.pinch.plant import RELEASE_S
from hand_service.pinch.tuning import RULES
from hand_service.replicate.pinch_run import measured_controller

VARIANTS: dict[str, Mismatch] = {
    "mismatched (all parts)": PAPER_MISMATCH,
    "without stiffening": dataclasses.replace(PAPER_MISMATCH, stiffening=0.0),
    "without the moving contact point": dataclasses.replace(PAPER_MISMATCH, lever_drift_per_rad=0.0),
    "without the sensor's bow": dataclasses.replace(PAPER_MISMATCH, sensor_bow_deg=0.0),
    "without hysteresis": dataclasses.replace(PAPER_MISMATCH, hysteresis_deg=0.0),
    "without the board's valves": dataclasses.replace(PAPER_MISMATCH, valves=None),
    "the PRBM plant (none)": NONE,
}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m hand_service.pinch.ablation", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--object", choices=[o.name for o in OBJECTS], default="chip")
    parser.add_argument("--trials", type=int, default=50, help="trials a cell (default 50)")
    parser.add_argument("--rule", choices=sorted(RULES), default="operator",
                        help="tuning rule (default operator)")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--release-s", type=float, default=RELEASE_S,
                        help=f"the person's hand opens over this time (default {RELEASE_S:g} s)")
    parser.add_argument("--full-only", action="store_true", help="the mismatched plant alone")
    args = parser.parse_args(argv)
    if args.trials < 1:
        parser.error("--trials must be 1 or more")
    if not 0.0 <= args.release_s <= 5.0:
        parser.error("--release-s must be 0 to 5")
    obj = next(o for o in OBJECTS if o.name == args.object)
    truth, measured = measured_controller(None, args.seed, 10)
    print(f"| plant ({obj.name}, {args.trials} trials a cell, {RULES[args.rule].describe()}, "
          f"release over {args.release_s:g} s) | force control "
          "| constant pressure | paired difference (points, 95 % CI) | McNemar p | force control's failures "
          "| estimate RMS error (N) |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    variants = list(VARIANTS.items())[:1] if args.full_only else list(VARIANTS.items())
    for name, mismatch in variants:
        controller = measured
        if mismatch != NONE:
            with tempfile.TemporaryDirectory(prefix="pinch-ablation-") as scratch:
                controller = identify_on_plant(truth, measured, mismatch, args.seed, Path(scratch))
        result = run_pinch(truth, controller, args.trials, args.seed, objects=(obj,), rule=RULES[args.rule],
                           mismatch=mismatch, release_s=args.release_s)
        (sf, nf), (sp, n_p) = result.pooled("force", obj.name), result.pooled("pressure", obj.name)
        paired = result.paired(obj.name)
        low, high = paired.interval
        failures: dict[str, int] = {}
        for cell in result.cells:
            if cell.controller == "force" and cell.obj == obj.name:
                for kind, count in cell.failures.items():
                    failures[kind] = failures.get(kind, 0) + count
        told = ", ".join(f"{count} {kind}" for kind, count in sorted(failures.items())) or "none"
        print(f"| {name} | {100 * sf / nf:.1f} % | {100 * sp / n_p:.1f} % | {100 * paired.difference:+.1f} "
              f"[{100 * low:+.1f}, {100 * high:+.1f}] | {paired.mcnemar_p:.2g} | {told} | "
              f"{result.estimate_rmse_n['force']:.3f} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
