"""A model in the wrong units, told in one line before any fit: one that the recorded
command drives to angles no finger has (a finger that rings far faster than the recording
samples: hand_service/simulator.py, check_ringing)."""

from __future__ import annotations

import math

import numpy as np

from hand_service.config.model import FingerModel
from hand_service.errors import UserError

ANGLE_LIMIT_DEG = 1e6  # the recording reader's bound on an angle (hand_service/recording.py)


def check_nominal(model: FingerModel, angle_deg: np.ndarray) -> None:
    """The model as given, driven by the recorded command, must give angles a finger could
    have: a model in the wrong units otherwise, said in one line."""
    worst = float(np.max(np.abs(angle_deg))) if np.all(np.isfinite(angle_deg)) else math.inf
    if worst > ANGLE_LIMIT_DEG:
        raise UserError(f"{model.source}: driven by the recorded command, the model's finger reaches "
                        f"{worst:.3g}° (beyond {ANGLE_LIMIT_DEG:g}°): are B (N·m·s/rad), k (N·m/rad) and N "
                        "(N·m/kPa) in their units?")
