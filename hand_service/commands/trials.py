"""`hand-service trials`: simulated lab recordings for identify and calibrate."""

from __future__ import annotations

import argparse
from pathlib import Path

HELP = "simulate lab trials (releases, pressure sweeps, valve steps, sensor pairs) as CSV"
DESCRIPTION = """\
Write simulated recordings (docs/formats.md) of the profile's simulated hand, deterministic for
a seed, with the profile's sensor noise and ADC:

  release  push the tip to an offset (25-40 deg), hold 1 s, release at a random instant
           between samples, record 4 s of free oscillation (for identify)
  sweep    a slow raised-cosine pressure sweep 0 -> limit -> 0 over 20 s with the
           measured chamber pressure (for calibrate gain)
  valve    pressure steps with the measured chamber pressure (for calibrate valve)
  pairs    sensor mV against reference angles 0-150 deg (for calibrate sensor)

Files are named <finger>_<kind>_<nn>.csv. Example, Table 1's trials:
  hand-service trials release --count 10 --out trials/
  hand-service identify trials/index_release_*.csv --model firmware_profiles/sim.yaml --finger index
"""


MAX_COUNT = 10_000  # recordings per finger; far beyond any statistic, short of filling a disk


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("kind", choices=["release", "sweep", "valve", "pairs"])
    parser.add_argument("--out", type=Path, required=True, metavar="DIR", help="directory for the CSV files")
    parser.add_argument("--profile", default=None, help="the simulated hand (default: sim.yaml)")
    parser.add_argument("--finger", action="append", help="only this finger (repeatable; default: all)")
    parser.add_argument("--count", type=int, default=1,
                        help=f"recordings per finger (1 to {MAX_COUNT}; default 1)")
    parser.add_argument("--seed", type=int, default=1, help="seed (default 1)")
    parser.add_argument("--rate", type=float, default=None, help="sample rate in Hz (default: the profile's)")
    parser.add_argument("--quiet", action="store_true",
                        help="no progress on stderr (else a bar on a terminal, a line every few "
                             "seconds elsewhere)")


def main(args: argparse.Namespace) -> int:
    import numpy as np

    from hand_service.commands import checks
    from hand_service.commands.progress import Progress
    from hand_service.config.profile import load_profile
    from hand_service.errors import UserError
    from hand_service.identification import trials
    from hand_service.outputs import make_directory

    checks.seed(args.seed)
    if not 1 <= args.count <= MAX_COUNT:
        raise UserError(f"--count must be 1 to {MAX_COUNT}, not {args.count}")
    profile = load_profile(args.profile)
    rate = args.rate or profile.control.rate_hz
    if not 10.0 <= rate <= 10000.0:
        raise UserError(f"--rate {rate:g} Hz is outside 10 to 10000 Hz")
    fingers = [profile.finger(name) for name in args.finger] if args.finger else profile.fingers
    make_directory(args.out)
    sim = profile.simulation
    with Progress("trials", total=len(fingers) * args.count, quiet=args.quiet) as progress:
        for f_index, finger in enumerate(fingers):
            progress.say(f"simulating {finger.name}'s {args.kind} trials")
            seeds = np.random.SeedSequence([args.seed, f_index]).generate_state(args.count)
            if args.kind == "release":
                made = trials.release_trials(finger, sim, args.count, int(seeds[0]), rate_hz=rate)
            elif args.kind == "pairs":
                made = [trials.sensor_pairs(finger, sim, int(s)) for s in seeds]
            else:
                make = {"sweep": trials.pressure_sweep, "valve": trials.valve_steps}[args.kind]
                made = [make(finger, sim, int(s), rate_hz=rate) for s in seeds]
            for i, trial in enumerate(made):
                name = f"{finger.name}_{args.kind}_{i:02d}.csv"
                trial.write(args.out / name)
                progress.advance(message=f"wrote {name}")
            progress.write(f"{finger.name}: {len(made)} {args.kind} recording(s) in {args.out}")
        progress.done()
    return 0
