"""Reference trajectories with the derivatives the dynamic feedforward needs."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class References:
    angle_deg: np.ndarray
    velocity_deg_per_s: np.ndarray
    accel_deg_per_s2: np.ndarray
    jerk_deg_per_s3: np.ndarray


@dataclass(frozen=True)
class CosineSweep:
    """The paper's test: θ = A·(1 − cos(2πt/T)), 0 → 2A → 0 every period (A = 45°, T = 0.75 s)."""

    amplitude_deg: float = 45.0
    period_s: float = 0.75

    def at(self, t_s: np.ndarray | float) -> References:
        t = np.asarray(t_s, dtype=float)
        w = 2.0 * math.pi / self.period_s
        a = self.amplitude_deg
        return References(a * (1.0 - np.cos(w * t)), a * w * np.sin(w * t),
                          a * w * w * np.cos(w * t), -a * w**3 * np.sin(w * t))
