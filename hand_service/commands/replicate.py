"""`hand-service replicate`: the paper's tables reproduced in simulation."""

from __future__ import annotations

import argparse
from pathlib import Path

HELP = "reproduce the paper's Table 1, Table 2 and force test on the simulated hand"
DESCRIPTION = """\
Reproduce the paper's results entirely in simulation, with valve dynamics (the profile's
valve lag, at least 30 ms, and dead time) and sensor noise (at least 0.3 deg).

The controller knows only what a lab would measure: every finger's sensor map
(calibrate sensor), k and B (identify on simulated push-and-release trials), valve lag
and dead time (calibrate valve) and N (calibrate gain on a slow sweep), all from
simulated recordings; the mass and geometry (A, lever arm) are taken as weighed.

Table 1   k and B per finger against the paper (and the two-peak recipe's errors).
Table 2   45*(1 - cos(2 pi t / 0.75 s)) for 10 periods, the first left out: RMSE and max
          error of PRBM+LDM feedforward + PID (the profile's gains) against PID alone,
          tuned per finger to its best on this very task (see docs/replicate.md).
Force     each finger at 90 deg against an object, the pressure ramped until the true
          force reaches 2 N: the controller's estimate against the true force.

With --pinch, instead: the paper's pinch test (Tables 3 and 4). Thumb and one finger
close on a potato chip, a screwdriver or a brass coin placed by a person's hand with a
random offset; success is the object held 5 s after release, unbroken and not slipped
out. PRBM+LDM force control against one constant pressure, each tuned once per object
on a centred placement (or per finger pair: --pinch-rule); --pinch-trials N trials per
finger pair and object (10 as the paper; 200 or more for 95 % Wilson intervals that
separate the two). Objects, contacts
and every parameter's source: docs/replicate.md.

Markdown tables go to stdout (stderr with --json -), progress to stderr: a bar on a
terminal, else a line every few seconds (none with --quiet), then the wall time.
"""


MAX_PINCH_TRIALS = 5000


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", type=Path, metavar="OUT.json", help="write JSON ('-': stdout)")
    parser.add_argument("--plots", type=Path, metavar="DIR", help="write the figures into this directory")
    parser.add_argument("--profile", type=Path, default=None, help="the simulated truth (default: sim.yaml)")
    parser.add_argument("--trials", type=Path, metavar="DIR", help="keep the simulated recordings here")
    parser.add_argument("--seed", type=int, default=1, help="seed of every simulated run (default 1)")
    parser.add_argument("--pinch", action="store_true",
                        help="run the pinch test (Tables 3 and 4) instead of Tables 1 and 2")
    parser.add_argument("--pinch-trials", type=int, default=None, metavar="N",
                        help="pinch trials per finger pair, object and controller (default 10)")
    parser.add_argument("--pinch-rule", choices=("object", "operator", "human"), default=None,
                        help="how the pinch setpoints are tuned: once per object on thumb & index "
                             "(object, the default), or per finger pair by the operator's written rule "
                             "(3 of 3 grasps x 1.25) or the human-like one (1 centred grasp x 1.5); "
                             "docs/replicate.md")
    parser.add_argument("--pinch-plant", choices=("model", "mismatched"), default=None,
                        help="the pinch's simulated hand: the controller's PRBM (model, the default) or "
                             "one that differs from it as a real hand does (stiffening, a moving contact, a "
                             "bowed sensor, hysteresis, the board's valves), calibrated again on it "
                             "(mismatched); docs/replicate.md")
    parser.add_argument("--quick", action="store_true",
                        help="3 trials a finger, 3 periods, a coarse PID search: seconds, not the "
                             "real figures")
    parser.add_argument("--quiet", action="store_true",
                        help="no progress on stderr (else a bar on a terminal, a line every few "
                             "seconds elsewhere)")


def main(args: argparse.Namespace) -> int:
    import sys

    from hand_service.commands import checks
    from hand_service.commands.progress import Progress
    from hand_service.jsonio import tables_out, write_json
    from hand_service.outputs import check_writable, make_directory
    from hand_service.replicate.run import Options, replicate

    checks.seed(args.seed)
    if args.json is not None:
        check_writable(args.json)
    for directory in (args.plots, args.trials):
        if directory is not None:
            make_directory(directory)  # now, not after minutes of simulation

    for given, option in ((args.pinch_trials, "--pinch-trials"), (args.pinch_rule, "--pinch-rule"),
                          (args.pinch_plant, "--pinch-plant")):
        if given is not None and not args.pinch:
            from hand_service.errors import UserError

            raise UserError(f"{option} needs --pinch")
    if args.pinch:
        return pinch_main(args)
    chosen = {"profile": args.profile, "seed": args.seed, "trials_dir": args.trials}
    options = Options.quick_run(**chosen) if args.quick else Options(**chosen)

    with tables_out(args.json), Progress("replicate", quiet=args.quiet) as progress:
        result = replicate(options, progress)
        print(result.tables())
        if args.plots is not None:
            from hand_service.replicate.plots import write_plots

            progress.say(f"writing the figures into {args.plots}")
            for path in write_plots(result, args.plots):
                print(f"wrote {path}", file=sys.stderr)
        if args.json is not None:
            write_json(args.json, result.to_json())
        progress.done()  # the wall time since the process started, not the simulations' alone
    return 0


def pinch_main(args: argparse.Namespace) -> int:
    import sys

    from hand_service.commands import checks
    from hand_service.errors import UserError
    from hand_service.jsonio import tables_out, write_json
    from hand_service.pinch.mismatch import PLANTS
    from hand_service.pinch.tuning import RULES
    from hand_service.replicate.pinch_run import PAPER_TRIALS_PER_CELL, replicate_pinch

    trials = PAPER_TRIALS_PER_CELL if args.pinch_trials is None else args.pinch_trials
    checks.seed(args.seed)
    if not 1 <= trials <= MAX_PINCH_TRIALS:
        raise UserError(f"--pinch-trials must be a whole number from 1 to {MAX_PINCH_TRIALS}, not {trials}")
    if args.trials is not None:
        raise UserError("--trials DIR keeps the recordings of Tables 1 and 2; the pinch run keeps none")

    def progress(message: str) -> None:
        print(f"replicate: {message}", file=sys.stderr, flush=True)

    with tables_out(args.json):
        from hand_service.pinch.tables import markdown

        result = replicate_pinch(args.profile, args.seed, trials, 3 if args.quick else 10, progress,
                                 RULES[args.pinch_rule or "object"], PLANTS[args.pinch_plant or "model"])
        print(markdown(result))
        if args.plots is not None:
            from hand_service.pinch.plots import write_pinch_plots

            for path in write_pinch_plots(result, args.plots):
                print(f"wrote {path}", file=sys.stderr)
    progress(f"done in {result.seconds:.1f} s")
    if args.json is not None:
        write_json(args.json, result.to_json())
    return 0
