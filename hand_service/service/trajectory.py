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


NOT_DRIVEN = -1  # Trajectory.mode: this finger follows its API target instead


@dataclass
class Trajectory:
    """References on the tick grid (row k at t = k / rate_hz), one column per finger.

    mode[k, i] is the finger's rtcore mode at tick k (MODE_POSITION, MODE_FORCE or
    MODE_VENT), or NOT_DRIVEN. Position rows carry the angle and its derivatives (for the
    dynamic feedforward), force rows the signed normal force; the rest is NaN.
    """

    rate_hz: float
    mode: np.ndarray
    angle_deg: np.ndarray
    velocity_deg_per_s: np.ndarray
    accel_deg_per_s2: np.ndarray
    jerk_deg_per_s3: np.ndarray
    force_n: np.ndarray
    source: str = ""

    @classmethod
    def empty(cls, n_ticks: int, n_fingers: int, rate_hz: float, source: str = "") -> Trajectory:
        def nan() -> np.ndarray:
            return np.full((n_ticks, n_fingers), np.nan)
        return cls(rate_hz, np.full((n_ticks, n_fingers), NOT_DRIVEN, dtype=np.int32), nan(), nan(),
                   nan(), nan(), nan(), source)

    @property
    def n_ticks(self) -> int:
        return int(self.mode.shape[0])

    @property
    def duration_s(self) -> float:
        return self.n_ticks / self.rate_hz

    def driven(self) -> np.ndarray:
        """Which fingers the trajectory drives at some point."""
        return (self.mode != NOT_DRIVEN).any(axis=0)

    def checked_driven(self) -> np.ndarray:
        """Which fingers it drives; a ValueError unless it drives each at every tick or never
        (checking an hour of trajectory takes milliseconds: off the loop)."""
        driven = self.driven()
        if ((self.mode == NOT_DRIVEN) != ~driven).any():
            raise ValueError("a trajectory drives a finger at every tick or never")
        return driven

    def set_position(self, rows: slice, finger: int, refs: References) -> None:
        from rtcore import MODE_POSITION
        self.mode[rows, finger] = MODE_POSITION
        self.angle_deg[rows, finger] = refs.angle_deg
        self.velocity_deg_per_s[rows, finger] = refs.velocity_deg_per_s
        self.accel_deg_per_s2[rows, finger] = refs.accel_deg_per_s2
        self.jerk_deg_per_s3[rows, finger] = refs.jerk_deg_per_s3

    def set_force(self, rows: slice, finger: int, force_n: np.ndarray | float) -> None:
        from rtcore import MODE_FORCE
        self.mode[rows, finger] = MODE_FORCE
        self.force_n[rows, finger] = force_n

    def derive(self) -> None:
        """Velocity, acceleration and jerk of the position rows by finite differences
        (for trajectories given as samples only)."""
        from rtcore import MODE_POSITION
        dt = 1.0 / self.rate_hz
        position = self.mode == MODE_POSITION
        angle = np.where(position, self.angle_deg, np.nan)
        derivatives = []
        for _ in range(3):
            angle = np.gradient(angle, dt, axis=0) if angle.shape[0] > 1 else np.zeros_like(angle)
            derivatives.append(np.where(position, np.nan_to_num(angle, nan=0.0), np.nan))
            angle = np.where(position, derivatives[-1], np.nan)
        self.velocity_deg_per_s, self.accel_deg_per_s2, self.jerk_deg_per_s3 = derivatives


@dataclass(frozen=True)
class SmoothStep:
    """A minimum-jerk move from a to b over duration_s: smooth to the third derivative."""

    start_deg: float
    end_deg: float
    duration_s: float

    def at(self, t_s: np.ndarray | float) -> References:
        d = self.duration_s
        s = np.clip(np.asarray(t_s, dtype=float) / d, 0.0, 1.0)
        span = self.end_deg - self.start_deg
        pos = 10 * s**3 - 15 * s**4 + 6 * s**5
        vel = (30 * s**2 - 60 * s**3 + 30 * s**4) / d
        acc = (60 * s - 180 * s**2 + 120 * s**3) / d**2
        jerk = (60 - 360 * s + 360 * s**2) / d**3
        inside = (s > 0) & (s < 1)
        return References(self.start_deg + span * pos, span * vel * inside, span * acc * inside,
                          span * jerk * inside)
