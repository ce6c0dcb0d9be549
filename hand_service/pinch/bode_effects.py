"""Which of the effects `diagnose` wrote moves impedance mode's rendered stiffness, and
which part of the plant is left: hand_service.pinch.bode's probe on one plant, the
controller calibrated (`calibrate sensor`, `calibrate gain`) or after the lab's valve fit
and `diagnose` (hand_service.pinch.lab_diagnose), then that model with each effect
diagnose named taken out in turn; then the same on the plant with each of its parts taken
out in turn (hand_service.pinch.ablation.VARIANTS, its valves evened as the plant's), the
lab's runs made again on each.

    python -m hand_service.pinch.bode_effects [--finger index] [--share 1.0]
                                              [--plant mismatched-even-valves] [--amplitude-deg 2]

Prints one markdown table: per plant and controller, diagnose's verdict and effects, and
the stiffness's error against the set K (%) at each of FREQUENCIES_HZ ("saturated" as in
bode); then, per controller on the first plant, the finger left alone in impedance mode
about the 80° reference (no probe, REST_S): the mean angle and the peak-to-peak of the
angle and the chamber over the last LAST_S, where a loop the hysteresis inverse made
unstable would swing; and the same on the PRBM plant, which has no loop, with the truth's
model and with diagnose's loop added to it (a false positive). --rest-only prints these
alone.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import tempfile
from pathlib import Path

import numpy as np

from hand_service.api.impedance import gain_limits
from hand_service.config.profile import Profile, load_profile
from hand_service.pinch.ablation import VARIANTS
from hand_service.pinch.bode import AMPLITUDE_DEG, BODE_PLANTS, DAMPING_N_S_PER_DEG, REFERENCE_DEG, rendered
from hand_service.pinch.compliance import closed_loop
from hand_service.pinch.lab_diagnose import EVEN_VALVES, diagnosed_controller
from hand_service.pinch.mismatch import NONE, Mismatch, identify_on_plant

FREQUENCIES_HZ = (0.1, 0.5, 1.0, 2.0)
REST_S = 8.0
LAST_S = 3.0


def at_rest(truth: Profile, controller: Profile, finger: str, k_set: float, plant: Mismatch) -> str:
    """The free finger about the reference, as the table's cells: mean angle; p-p angle; p-p chamber."""
    loop = closed_loop(truth, finger, k_set, DAMPING_N_S_PER_DEG, REST_S, lambda _: REFERENCE_DEG,
                       lambda _: None, 1, controller, mismatch=plant)
    last = round(LAST_S * truth.control.rate_hz)
    angle, chamber = loop.angle_deg[-last:], loop.chamber_kpa[-last:]
    return f"{angle.mean():.2f} | {np.ptp(angle):.2f} | {np.ptp(chamber):.2f}"


def without_effect(controller: Profile, finger: str, name: str) -> Profile:
    """The controller with one effect taken out of one finger's model."""
    fingers = [dataclasses.replace(f, model=f.model.with_changes(
        effects={k: v for k, v in f.model.effects.items() if k != name})) if f.name == finger else f
        for f in controller.fingers]
    return dataclasses.replace(controller, fingers=fingers)


def with_effect(controller: Profile, finger: str, name: str, values: dict[str, float]) -> Profile:
    """The controller with one effect put into one finger's model."""
    fingers = [dataclasses.replace(f, model=f.model.with_changes(effects={**f.model.effects, name: values}))
               if f.name == finger else f for f in controller.fingers]
    return dataclasses.replace(controller, fingers=fingers)


def controllers(truth: Profile, finger: str, plant: Mismatch, seed: int) -> tuple[dict[str, Profile], str]:
    """The calibrated controller, the diagnosed one and the diagnosed one without each effect
    diagnose named, by label; and diagnose's verdict and effects in words."""
    with tempfile.TemporaryDirectory(prefix="pinch-bode-effects-") as scratch:
        calibrated = identify_on_plant(truth, truth, plant, seed, Path(scratch))
    diagnosed, (found,) = diagnosed_controller(truth, calibrated, plant, seed, [finger])
    runs = {"calibrated": calibrated, "diagnosed": diagnosed}
    for effect in found.diagnosis.effects:
        runs[f"diagnosed without {effect.name}"] = without_effect(diagnosed, finger, effect.name)
    return runs, f"{found.diagnosis.verdict}: {found.effects_said()}"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m hand_service.pinch.bode_effects", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--finger", default="index")
    parser.add_argument("--share", type=float, default=1.0, help="K as a share of K_max (default 1)")
    parser.add_argument("--plant", choices=("mismatched", "mismatched-even-valves"),
                        default="mismatched-even-valves")
    parser.add_argument("--amplitude-deg", type=float, default=AMPLITUDE_DEG)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--rest-only", action="store_true", help="only the finger left alone")
    args = parser.parse_args(argv)
    if not 0.0 < args.share <= 1.0:
        parser.error("--share must be above 0 and at most 1")
    truth = load_profile(None)
    k_set = args.share * gain_limits(truth.finger(args.finger).model)[0]
    base = BODE_PLANTS[args.plant]
    plants = {args.plant: base}
    for name, variant in list(VARIANTS.items())[1:-1]:  # each part out; not the whole, not none
        if base is EVEN_VALVES and variant.valves is not None:
            variant = dataclasses.replace(variant, valves=base.valves)
        plants[f"{args.plant} {name}"] = variant
    base_runs, base_said = controllers(truth, args.finger, base, args.seed)
    if not args.rest_only:
        print(f"{args.finger}, K = {k_set:.4f} N/deg ({args.share:g} K_max), push K·{args.amplitude_deg:g}° "
              f"about {REFERENCE_DEG:g}°: stiffness error against K (%)\n")
        head = " | ".join(f"{f:g} Hz" for f in FREQUENCIES_HZ)
        print(f"| plant | controller | diagnose said | {head} |")
        print("| --- | --- | --- |" + " --- |" * len(FREQUENCIES_HZ))
        for plant_name, plant in plants.items():
            runs, said = (base_runs, base_said) if plant is base else controllers(truth, args.finger, plant,
                                                                                   args.seed)
            for label, controller in runs.items():
                cells = []
                for f in FREQUENCIES_HZ:
                    p = rendered(truth, controller, args.finger, k_set, f, mismatch=plant,
                                 amplitude_deg=args.amplitude_deg)
                    cells.append(f"{100 * (p.stiffness_n_per_deg / k_set - 1):+.1f}"
                                 + (" (saturated)" if p.saturated else ""))
                print(f"| {plant_name} | {label} | {said if label != 'calibrated' else ''} | "
                      + " | ".join(cells) + " |", flush=True)
    rest = {(args.plant, label): at_rest(truth, c, args.finger, k_set, base)
            for label, c in base_runs.items()}
    loop = base_runs["diagnosed"].finger(args.finger).model.effects.get("hysteresis")
    if loop is not None:  # a false positive: the loop in the model (and in force), not in the plant
        rest[("PRBM", "the truth's model")] = at_rest(truth, truth, args.finger, k_set, NONE)
        lab_control = dataclasses.replace(truth, control=base_runs["diagnosed"].control)
        rest[("PRBM", "the truth's model with diagnose's loop")] = at_rest(
            truth, with_effect(lab_control, args.finger, "hysteresis", loop), args.finger, k_set, NONE)
    print(f"\n{args.finger} at {args.share:g} K_max left alone ({REST_S:g} s, the last {LAST_S:g} s):\n")
    print("| plant | controller | mean angle (deg) | angle peak-to-peak (deg) | chamber peak-to-peak (kPa) |")
    print("| --- | --- | --- | --- | --- |")
    for (plant_name, label), cells in rest.items():
        print(f"| {plant_name} | {label} | {cells} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
