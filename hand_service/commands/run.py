"""`hand-service run`: run the controller. Until the supervisor daemon lands, this runs the
closed-loop demo on the simulated hand of the profile."""

from __future__ import annotations

import argparse

HELP = "run the controller on a hand (default: the simulated hand of sim.yaml)"
DESCRIPTION = """\
Run the controller. With the default profile (firmware_profiles/sim.yaml) the hand is
simulated in this process, so nothing else is needed: every finger tracks the paper's
0 -> 90 deg cosine sweep (0.75 s period) and the tracking and timing figures are printed.
"""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--profile", default=None, help="firmware profile (default: sim.yaml)")
    parser.add_argument("--periods", type=int, default=8, help="sweep periods to run (default 8)")


def main(args: argparse.Namespace) -> int:
    from hand_service.demo import track_sweep
    from hand_service.errors import UserError
    from hand_service.profile import load_profile

    profile = load_profile(args.profile)
    if profile.transport["kind"] != "sim":
        raise UserError(f"{profile.path}: this build runs only the simulated hand (transport sim)")
    if args.periods < 2:
        raise UserError("--periods must be at least 2 (the first period is left out)")
    print(f"profile {profile.name}: {len(profile.fingers)} fingers at {profile.control['rate_hz']:g} Hz, "
          f"tracking 45*(1 - cos(2 pi t / 0.75 s)) for {args.periods} periods")
    result = track_sweep(profile, periods=args.periods, progress=True)
    print(f"{'finger':<8} {'RMSE (deg)':>11} {'max error (deg)':>16}")
    for name, rmse, worst in zip(result.fingers, result.rmse_deg, result.max_error_deg, strict=True):
        print(f"{name:<8} {rmse:11.2f} {worst:16.2f}")
    print(f"{'mean':<8} {result.rmse_deg.mean():11.2f} {result.max_error_deg.mean():16.2f}")
    print(f"control step: p50 {result.step_ns_p50:.0f} ns, p99 {result.step_ns_p99:.0f} ns "
          f"over {result.ticks} ticks")
    return 0
