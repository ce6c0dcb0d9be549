"""Impedance mode's compliance over a tenfold range of stiffness, for every finger: the
table of docs/replicate.md.

    python -m hand_service.pinch.compliance_table [--seeds 3] [--damping 0] [--measured] [--model-error-pct P]

Per finger, K at a tenth, three tenths and all of its stable limit (hand_service.api.impedance),
each pushed slowly (hand_service.pinch.compliance.slow_push) under several noise seeds:
the measured stiffness's error against K, its range over the seeds. With --measured the
controller's finger model is the one a lab measures on the simulated hand (10 releases a
finger, as replicate --pinch), not the truth's: its force estimate is then not exact.
With --model-error-pct P the controller's joint stiffness k is P % above the truth's and
its pressure gain N P % below (a calibration error in the direction that biases the
estimate most; on top of --measured if given).
"""

from __future__ import annotations

import argparse
import sys

from hand_service.api.impedance import gain_limits
from hand_service.config.profile import Profile, load_profile
from hand_service.pinch.compliance import miscalibrated, slow_push

SHARES_OF_LIMIT = (0.1, 0.3, 1.0)


def errors_pct(truth: Profile, controller: Profile, finger: str, stiffness_n_per_deg: float,
               damping_n_s_per_deg: float, seeds: int) -> list[float]:
    return [100.0 * slow_push(truth, finger, stiffness_n_per_deg, damping_n_s_per_deg, seed=seed,
                              controller=controller).error_ratio for seed in range(1, seeds + 1)]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m hand_service.pinch.compliance_table",
                                     description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, default=3, help="noise seeds per cell (default 3)")
    parser.add_argument("--damping", type=float, default=0.0, help="virtual damping D, N s/deg (default 0)")
    parser.add_argument("--measured", action="store_true",
                        help="the controller knows the lab-measured model, not the truth's")
    parser.add_argument("--model-error-pct", type=float, default=0.0, metavar="P",
                        help="the controller's k P %% high and N P %% low (default 0)")
    args = parser.parse_args(argv)
    if args.seeds < 1:
        parser.error("--seeds must be 1 or more")
    if not 0.0 <= args.model_error_pct < 50.0:
        parser.error("--model-error-pct must be 0 to 50")
    truth = load_profile(None)
    controller = truth
    if args.measured:
        from hand_service.replicate.pinch_run import measured_controller

        truth, controller = measured_controller(None, 1, 10)
    model = "lab-measured model" if args.measured else "the truth's model"
    if args.model_error_pct:
        controller = miscalibrated(controller, args.model_error_pct)
        model += f", k +{args.model_error_pct:g} %, N -{args.model_error_pct:g} %"
    print(f"| finger ({model}, D = {args.damping:g}) | "
          + " | ".join(f"K = {s:g} K_max" for s in SHARES_OF_LIMIT) + " |")
    print("| --- |" + " --- |" * len(SHARES_OF_LIMIT))
    for f in truth.fingers:
        k_max = gain_limits(controller.finger(f.name).model)[0]
        cells = []
        for share in SHARES_OF_LIMIT:
            got = errors_pct(truth, controller, f.name, share * k_max, args.damping, args.seeds)
            cells.append(f"{share * k_max:.4f} N/deg: {min(got):+.1f} to {max(got):+.1f} %")
        print(f"| {f.name} | " + " | ".join(cells) + " |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
