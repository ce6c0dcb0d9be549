"""Which part of the mismatched plant moves the rendered stiffness: impedance mode's probe
(hand_service.pinch.bode) on the mismatched plant with each of its parts taken out in
turn (hand_service.pinch.ablation.VARIANTS), the controller the truth's model with the
lab's `calibrate sensor` and `calibrate gain` run again on each plant; then the whole
mismatched plant under pushes of other amplitudes, where the silicone's hysteresis (a
friction of the joint) weighs less.

    python -m hand_service.pinch.bode_parts [--finger index] [--reference-deg 80]
                                            [--amplitude-deg 2 --amplitude-deg 5 ...]

Prints one markdown table: per plant and push amplitude, the N that `calibrate gain`
measures against the truth's (%), and the stiffness's error against the set K = K_max (%)
at each of FREQUENCIES_HZ ("saturated" as in bode).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

from hand_service.api.impedance import gain_limits
from hand_service.config.profile import load_profile
from hand_service.pinch.ablation import VARIANTS
from hand_service.pinch.bode import AMPLITUDE_DEG, REFERENCE_DEG, rendered
from hand_service.pinch.mismatch import PAPER_MISMATCH, identify_on_plant

FREQUENCIES_HZ = (0.1, 0.5, 1.0, 2.0)
AMPLITUDES_DEG = (2.0, 5.0, 10.0)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m hand_service.pinch.bode_parts", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--finger", default="index")
    parser.add_argument("--reference-deg", type=float, default=REFERENCE_DEG)
    parser.add_argument("--amplitude-deg", type=float, action="append",
                        help=f"push amplitudes for the whole plant (default {AMPLITUDES_DEG})")
    args = parser.parse_args(argv)
    truth = load_profile(None)
    k_set = gain_limits(truth.finger(args.finger).model)[0]
    amplitudes = tuple(args.amplitude_deg or AMPLITUDES_DEG)
    runs = [(name, plant, AMPLITUDE_DEG) for name, plant in VARIANTS.items()]
    runs += [("mismatched (all parts)", PAPER_MISMATCH, a) for a in amplitudes if a != AMPLITUDE_DEG]
    print(f"{args.finger}, K = K_max = {k_set:.4f} N/deg about {args.reference_deg:g}°: stiffness error "
          f"against K (%)\n")
    print("| plant | push | N by calibrate gain | " + " | ".join(f"{f:g} Hz" for f in FREQUENCIES_HZ) + " |")
    print("| --- | --- | --- |" + " --- |" * len(FREQUENCIES_HZ))
    with tempfile.TemporaryDirectory(prefix="pinch-bode-parts-") as scratch:
        calibrated = {name: identify_on_plant(truth, truth, plant, 1, Path(scratch))
                      for name, plant in VARIANTS.items()}
    for name, plant, amplitude in runs:
        controller = calibrated[name]
        gain_pct = 100.0 * (controller.finger(args.finger).model.pressure_gain_nm_per_kpa
                            / truth.finger(args.finger).model.pressure_gain_nm_per_kpa - 1.0)
        cells = []
        for f in FREQUENCIES_HZ:
            p = rendered(truth, controller, args.finger, k_set, f, mismatch=plant, amplitude_deg=amplitude,
                         reference_deg=args.reference_deg)
            cells.append(f"{100 * (p.stiffness_n_per_deg / k_set - 1):+.1f}"
                         + (" (saturated)" if p.saturated else ""))
        print(f"| {name} | K·{amplitude:g}° | {gain_pct:+.1f} % | " + " | ".join(cells) + " |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
