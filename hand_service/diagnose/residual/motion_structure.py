"""Structure that grows with the finger's motion: what the noise model may have taken, measured
without a stretch at rest or a repeating command.

A sensor's noise does not know how fast the finger moves: its spread is the same in a second
where the finger swings as in one where it hardly moves. A torque the model misses (a
damping that depends on the pressure, a friction, a lag) acts while the finger moves, so the
misfit it leaves is larger where the finger moves most. The AR noise model (residual/noise.py)
takes a smooth misfit for correlated noise whatever its size, and its innovations come out
white; this test does not rest on them. The misfit (the sensor's offset and slow drift out)
is cut into windows of WINDOW_S; the windows are ranked by the model's mean squared speed,
and the misfit's RMS over the fastest third is set against the slowest third's.

A damping that grows with the chamber pressure, outside the library, is the case that
showed the need: its innovations passed the Ljung-Box test while its misfit grew with the
motion (docs/results.md §12.27 has the measured ratios, and those of clean recordings).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

WINDOW_S = 1.0  # several of the sensor's correlation times: a window's spread is its noise's
MIN_WINDOWS = 12  # a third of them, at least four, to rank against the other
# The fastest third's misfit RMS over the slowest third's, above which the misfit grows with
# the motion: a misfit in proportion to the speed, twice the noise over the recording, on a
# sweep whose fastest third moves four times as fast as its slowest, gives 2.4; the noise
# alone scatters about 1 by a fifth between thirds of 30 one-second windows (its correlation
# time up to 0.2 s).
STRUCTURE_RATIO = 2.0


@dataclass(frozen=True)
class MotionStructure:
    slow_deg: float  # the misfit's RMS over the slowest third of the windows
    fast_deg: float  # and over the fastest third
    slow_speed_deg_s: float  # the model's RMS speed over those windows
    fast_speed_deg_s: float
    windows: int

    @property
    def ratio(self) -> float:
        return self.fast_deg / self.slow_deg if self.slow_deg > 0.0 else float("inf")

    @property
    def exceeded(self) -> bool:
        return self.ratio > STRUCTURE_RATIO

    def sentence(self) -> str:
        return (f"the misfit grows with the finger's motion: {self.fast_deg:.3g} deg RMS over the third of "
                f"the recording where the model moves fastest ({self.fast_speed_deg_s:.4g} deg/s RMS), "
                f"{self.ratio:.2g} times its {self.slow_deg:.3g} deg where it moves slowest "
                f"({self.slow_speed_deg_s:.4g} deg/s): a sensor's noise does not know how fast the finger "
                "moves, so this is input-driven structure the noise model takes for correlated noise")


def motion_structure(misfit_deg: np.ndarray, angle_deg: np.ndarray, valid: np.ndarray,
                     rate_hz: float) -> MotionStructure | None:
    """The misfit's RMS where the model (`angle_deg`, simulated) moves fastest against where
    it moves slowest, by windows of WINDOW_S; None where the recording has fewer than
    MIN_WINDOWS windows of data."""
    n = round(WINDOW_S * rate_hz)
    if n < 2:
        return None
    speed2 = (np.gradient(angle_deg) * rate_hz) ** 2
    kept = valid.astype(bool)
    m = misfit_deg - float(np.mean(misfit_deg[kept])) if kept.any() else misfit_deg
    misfit2, motion2 = [], []
    for start in range(0, m.size - n + 1, n):
        k = kept[start:start + n]
        if k.sum() < n // 2:
            continue
        misfit2.append(float(np.mean(m[start:start + n][k] ** 2)))
        motion2.append(float(np.mean(speed2[start:start + n][k])))
    if len(misfit2) < MIN_WINDOWS:
        return None
    order = np.argsort(motion2, kind="stable")
    third = len(order) // 3
    slow, fast = order[:third], order[-third:]
    ms, mo = np.array(misfit2), np.array(motion2)
    return MotionStructure(float(np.sqrt(ms[slow].mean())), float(np.sqrt(ms[fast].mean())),
                           float(np.sqrt(mo[slow].mean())), float(np.sqrt(mo[fast].mean())), len(misfit2))


__all__ = ["MotionStructure", "motion_structure"]
