"""`replicate --pinch`: the paper's pinch test (Tables 3 and 4) on the simulated hand.

As for the other tables, the controller knows only what the lab measured on simulated
recordings (hand_service.identification.measured_hand); the truth is the profile's hand,
driven by the pinch plant of hand_service.pinch with the daemon's C control step.
"""

from __future__ import annotations

import tempfile
from collections.abc import Callable
from pathlib import Path

import numpy as np

from hand_service.config.profile import Profile, load_profile
from hand_service.identification.measured_hand import controller_profile, measure_finger
from hand_service.pinch.experiment import PinchResult, run_pinch
from hand_service.pinch.mismatch import NONE, Mismatch, identify_on_plant
from hand_service.pinch.tuning import HAND_RULE, Rule
from hand_service.replicate.run import check_truth

PAPER_TRIALS_PER_CELL = 10


def measured_controller(profile: Path | None, seed: int, trials_per_finger: int,
                        progress: Callable[[str], None] | None = None) -> tuple[Profile, Profile]:
    """(the truth, the controller's profile from the lab's measurement of the simulated hand)."""
    say = progress or (lambda _: None)
    truth = load_profile(profile)
    check_truth(truth)
    seeds = [int(s) for s in np.random.SeedSequence([seed]).generate_state(len(truth.fingers))]
    missing = {"thumb", "index", "middle", "ring", "little"} - set(truth.finger_names)
    if missing:
        from hand_service.errors import UserError

        raise UserError(f"{truth.path}: the pinch needs the fingers thumb, index, middle, ring and little "
                        f"(missing: {', '.join(sorted(missing))})")
    with tempfile.TemporaryDirectory(prefix="replicate-pinch-") as scratch:
        say(f"measuring the simulated hand ({trials_per_finger} releases a finger)")
        measured = [measure_finger(f, truth.simulation, Path(scratch), trials_per_finger, seeds[i], say)
                    for i, f in enumerate(truth.fingers)]
    return truth, controller_profile(truth, measured)


def replicate_pinch(profile: Path | None, seed: int, trials_per_cell: int, trials_per_finger: int,
                    progress: Callable[[str], None] | None = None, rule: Rule = HAND_RULE,
                    mismatch: Mismatch = NONE) -> PinchResult:
    """The pinch run; with a mismatch, the plant differs from the PRBM and the lab calibrates
    the sensor and the pressure gain again on it (hand_service.pinch.mismatch)."""
    truth, controller = measured_controller(profile, seed, trials_per_finger, progress)
    if mismatch != NONE:
        with tempfile.TemporaryDirectory(prefix="replicate-pinch-plant-") as scratch:
            controller = identify_on_plant(truth, controller, mismatch, seed, Path(scratch))
        if progress:
            progress("pinch: sensor map and pressure gain calibrated again on the mismatched plant")
    return run_pinch(truth, controller, trials_per_cell, seed, progress, rule=rule, mismatch=mismatch)
