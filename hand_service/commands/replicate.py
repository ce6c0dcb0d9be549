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

Markdown tables go to stdout (stderr with --json -), progress to stderr.
"""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", type=Path, metavar="OUT.json", help="write JSON ('-': stdout)")
    parser.add_argument("--plots", type=Path, metavar="DIR", help="write the figures into this directory")
    parser.add_argument("--profile", type=Path, default=None, help="the simulated truth (default: sim.yaml)")
    parser.add_argument("--trials", type=Path, metavar="DIR", help="keep the simulated recordings here")
    parser.add_argument("--seed", type=int, default=1, help="seed of every simulated run (default 1)")
    parser.add_argument("--quick", action="store_true",
                        help="3 trials a finger, 3 periods, a coarse PID search: seconds, not the "
                             "real figures")


def main(args: argparse.Namespace) -> int:
    import sys

    from hand_service.commands import checks
    from hand_service.jsonio import tables_out, write_json
    from hand_service.outputs import check_writable, make_directory
    from hand_service.replicate.run import Options, replicate

    checks.seed(args.seed)
    if args.json is not None:
        check_writable(args.json)
    for directory in (args.plots, args.trials):
        if directory is not None:
            make_directory(directory)  # now, not after minutes of simulation

    chosen = {"profile": args.profile, "seed": args.seed, "trials_dir": args.trials}
    options = Options.quick_run(**chosen) if args.quick else Options(**chosen)

    def progress(message: str) -> None:
        print(f"replicate: {message}", file=sys.stderr, flush=True)

    with tables_out(args.json):
        result = replicate(options, progress)
        print(result.tables())
        if args.plots is not None:
            from hand_service.replicate.plots import write_plots

            for path in write_plots(result, args.plots):
                print(f"wrote {path}", file=sys.stderr)
    progress(f"done in {result.seconds:.1f} s")
    if args.json is not None:
        write_json(args.json, result.to_json())
    return 0
