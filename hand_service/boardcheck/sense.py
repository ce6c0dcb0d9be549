"""What board-check's plant check expects of a finger's sensors, from the profile."""

from __future__ import annotations

import math
from dataclasses import dataclass

from hand_service.config.profile import FingerProfile


@dataclass(frozen=True)
class FingerSense:
    """What the profile says a finger's flex sensor reads and its model bends."""

    name: str
    gain_deg_per_mv: float  # the calibration: deg = gain·mV + offset
    bend_deg_per_kpa: float  # the model's static bend, N·p = k·θ

    @staticmethod
    def of(finger: FingerProfile) -> FingerSense:
        model = finger.model
        return FingerSense(finger.name, finger.sensor_gain_deg_per_mv,
                           model.pressure_gain_nm_per_kpa / model.stiffness_nm_per_rad * 180.0 / math.pi)
