"""The pinch result's sensitivity to the hand-tuning rule: one measurement of the simulated
hand, then the large run under each rule, pooled over the finger pairs.

    python -m hand_service.pinch.sensitivity [--trials 200] [--seed 1] [--quick]

Prints one markdown table: per rule and object, force control's and constant pressure's
success with 95 % Wilson intervals, the difference and the setpoints (N; kPa).
"""

from __future__ import annotations

import argparse
import sys

from hand_service.pinch.experiment import run_pinch
from hand_service.pinch.objects import OBJECT_NAMES, PAPER_LABELS
from hand_service.pinch.stats import wilson_interval
from hand_service.pinch.tuning import Rule
from hand_service.replicate.pinch_run import measured_controller

RULES = (Rule("margin", 1.25), Rule("margin", 1.5), Rule("margin", 2.0),
         Rule("middle", force_search_max_n=10.0), Rule("middle", force_search_max_n=25.0))


def _rate(successes: int, trials: int) -> str:
    low, high = wilson_interval(successes, trials)
    return f"{100 * successes / trials:.0f} % [{100 * low:.0f}, {100 * high:.0f}]"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m hand_service.pinch.sensitivity", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--trials", type=int, default=200, help="trials a cell (default 200)")
    parser.add_argument("--seed", type=int, default=1, help="the run's seed (default 1, as replicate)")
    parser.add_argument("--quick", action="store_true", help="measure the hand with 3 releases, not 10")
    args = parser.parse_args(argv)
    if args.trials < 1:
        parser.error("--trials must be 1 or more")
    truth, controller = measured_controller(None, args.seed, 3 if args.quick else 10)
    print("| rule | object | force control | constant pressure | difference (points) | setpoints (N; kPa) |")
    print("| --- | --- | --- | --- | --- | --- |")
    for rule in RULES:
        result = run_pinch(truth, controller, args.trials, args.seed, rule=rule)
        for obj in OBJECT_NAMES:
            (sf, nf), (sp, n_p) = result.pooled("force", obj), result.pooled("pressure", obj)
            force, pressure = (result.tuned[("index", obj, "force")],
                               result.tuned[("index", obj, "pressure")])
            print(f"| {rule.describe()} | {PAPER_LABELS[obj]} | {_rate(sf, nf)} | {_rate(sp, n_p)} | "
                  f"{100 * (sf / nf - sp / n_p):+.1f} | {force.setpoint_n:g}; {pressure.setpoint_kpa:g} |",
                  flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
