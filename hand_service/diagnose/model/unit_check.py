"""A model in the wrong units, told in one line before any fit: one that the recorded
command drives to angles no finger has (a finger that rings far faster than the recording
samples: hand_service/simulator.py, check_ringing)."""

from __future__ import annotations

import math

import numpy as np

from hand_service.config.model import FingerModel
from hand_service.errors import UserError

ANGLE_LIMIT_DEG = 1e6  # the recording reader's bound on an angle (hand_service/recording.py)


# A model whose finger moves less than this share of what the recorded one did is not
# this finger in other units, it is the units: A (kg·m²) given in g·mm² makes no motion.
STILL_SHARE = 1e-6
MOVED_DEG = 1.0  # the recorded finger must have moved this much for its stillness to say so


def check_nominal(model: FingerModel, angle_deg: np.ndarray, measured_deg: np.ndarray,
                  pressure_kpa: np.ndarray) -> None:
    """The model as given, driven by the recorded command, must give angles a finger could
    have, and must move where the recorded finger moved: a model in the wrong units
    otherwise, said in one line."""
    worst = float(np.max(np.abs(angle_deg))) if np.all(np.isfinite(angle_deg)) else math.inf
    if worst > ANGLE_LIMIT_DEG:
        raise UserError(f"{model.source}: driven by the recorded command, the model's finger reaches "
                        f"{worst:.3g}° (beyond {ANGLE_LIMIT_DEG:g}°): are B (N·m·s/rad), k (N·m/rad) and N "
                        "(N·m/kPa) in their units?")
    if not np.ptp(pressure_kpa) > 0.0:
        return  # a command that never changes drives nothing: a still model says nothing then
    moved = float(np.subtract(*np.nanpercentile(measured_deg, (99, 1))))
    # what the command's span could bend the model's finger, held: a gain far out of its
    # units moves it nothing, though the start's own settling may move it a little
    reach_deg = math.degrees(model.pressure_gain_nm_per_kpa * float(np.ptp(pressure_kpa))
                             / model.stiffness_nm_per_rad)
    motion = min(float(np.ptp(angle_deg)), reach_deg)
    if moved > MOVED_DEG and motion < STILL_SHARE * moved:
        raise UserError(f"{model.source}: driven by the recorded command, the model's finger moves "
                        f"{motion:.3g}° where the recorded one moved {moved:.3g}°: are A (kg·m²), "
                        "B (N·m·s/rad), k (N·m/rad) and N (N·m/kPa) in their units?")
