"""`hand-service identify`: stiffness and damping from free-oscillation trials (LDM)."""

from __future__ import annotations

import argparse
from pathlib import Path

HELP = "stiffness k and damping B of a finger from push-and-release trials (LDM)"
DESCRIPTION = """\
Fit free-oscillation recordings (push the fingertip, hold, release; the pressure column
may be all zero) with the logarithmic decrement method (docs/physics.md §2). In each trial
the release is found and the free decay after it is read; the results are listed per
trial and as mean ± std. The inertia A is held at the model's value (given, or from the
geometry), so k = A·ω_n² and B = 2·ζ·ω_n·A.

Methods:
  fit       (default) least squares of the exact damped sine to every sample of the
            decay, seeded by the sub-sample peaks: within 1 % in k at 100 Hz
  peaks     sub-sample crests and troughs over every cycle, by regression
  two-peak  the paper's recipe: two consecutive sample-exact peaks, δ = ln(x1/x2);
            for comparison (it is off by several % per trial at 100 Hz)

A warning says when the decrement drifts with the amplitude: the damping is then not
viscous (a constant loss per cycle is dry friction; docs/physics.md §4, `diagnose`).

Example:
  hand-service identify trials/index_*.csv --model firmware_profiles/sim.yaml \\
      --finger index --json index.json --plot index.png --write-model index.yaml
"""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("trials", nargs="+", type=Path, metavar="TRIAL.csv",
                        help="free-oscillation recordings (docs/formats.md), one release each")
    parser.add_argument("--model", required=True, type=Path, metavar="MODEL.yaml",
                        help="finger model or firmware profile (needs the inertia or the geometry)")
    parser.add_argument("--finger", help="finger name: picks the block of a profile and the columns "
                                         "of a multi-finger recording")
    parser.add_argument("--method", default="fit", choices=["fit", "peaks", "two-peak"],
                        help="how to read the decay (default: fit)")
    parser.add_argument("--json", type=Path, metavar="OUT.json", help="write JSON ('-': stdout)")
    parser.add_argument("--plot", type=Path, metavar="OUT.png", help="draw each fit over its data")
    parser.add_argument("--write-model", type=Path, metavar="OUT.yaml",
                        help="write the model with the new k and B (A and the rest unchanged)")


def main(args: argparse.Namespace) -> int:
    import sys

    from hand_service.config.model import save_model
    from hand_service.config.plausible import refuse_implausible, say_implausible
    from hand_service.config.profile import load_model
    from hand_service.identification.identify import identify_recordings
    from hand_service.jsonio import tables_out, write_json

    with tables_out(args.json):
        model = load_model(args.model, args.finger)
        say_implausible(model)
        result = identify_recordings(args.trials, model, args.finger, args.method)
        print(f"identify ({args.method}), finger {result.finger or '?'}, A = {model.inertia_kgm2:.5g} kg·m² "
              f"(held), {len(result.trials)} trial(s):\n")
        print(result.table())
        print(f"\nk = {result.stiffness_nm_per_rad:.5g} ± {result.std('stiffness_nm_per_rad'):.2g} N·m/rad, "
              f"B = {result.damping_nms_per_rad:.4g} ± {result.std('damping_nms_per_rad'):.2g} N·m·s/rad")
        for warning in result.warnings:
            print(f"warning: {warning}", file=sys.stderr)
        if args.plot is not None:
            from hand_service.identification.plots import identify_figure

            print(f"wrote {identify_figure(result, args.plot)}")
        if args.write_model is not None:
            updated = model.with_changes(stiffness_nm_per_rad=result.stiffness_nm_per_rad,
                                         damping_nms_per_rad=result.damping_nms_per_rad)
            refuse_implausible(updated, args.write_model)
            names = ", ".join(p.name for p in args.trials[:5]) + (" ..." if len(args.trials) > 5 else "")
            save_model(updated, args.write_model,
                       header=f"k and B from `hand-service identify --method {args.method}` on {names}\n"
                              f"(mean of {len(result.trials)} trials; A held at the model's value)")
            print(f"wrote {args.write_model}")
    if args.json is not None:
        write_json(args.json, result.to_json())
    return 0
