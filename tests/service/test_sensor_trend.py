"""The trend test's own arithmetic, on a synthetic innovation: a finger sweeping 60 ± 30° at
1 Hz whose innovation is a parameter error's (a share of θ) plus white noise, and, from 3 s
on, a drift. The rig-level cases are in test_plausibility.py and test_no_false_fault.py."""

from __future__ import annotations

import math

import numpy as np

from hand_service.service.sensor_trend import SensorTrend

PERIOD_S = 0.01
LIMIT_DEG_PER_S = 2.5
PERSIST = 10
DRIFT_FROM_S = 3.0


def sweep(trend: SensorTrend, noise_deg: float, drift_deg_per_s: float, seconds: float,
          seed: int = 0) -> tuple[float | None, list[float]]:
    """The drift's size when the trend faulted (None: no fault) and the trend's standard
    errors once warmed up."""
    rng = np.random.default_rng(seed)
    errors = []
    for k in range(round(seconds / PERIOD_S)):
        t_s = k * PERIOD_S
        phase = 2 * math.pi * t_s
        theta_rad = math.radians(60 + 30 * math.sin(phase))
        sensitive = np.array([[theta_rad, 0.1 * theta_rad, 0.01 * math.cos(phase)]])
        rate = np.array([math.radians(30) * 2 * math.pi * math.cos(phase)])
        drift_deg = drift_deg_per_s * max(0.0, t_s - DRIFT_FROM_S)
        innovation = np.array([5.0 + 0.08 * math.degrees(theta_rad) + noise_deg * rng.standard_normal()
                               + drift_deg])
        if trend.sample(1, innovation, sensitive, rate, np.array([True])) is not None:
            return drift_deg, errors
        if t_s > 2.0:
            errors.append(float(trend.trend_error_deg_per_s[0]))
    return None, errors


def trend_for(natural_rad_per_s: float, stated_noise_deg: float = 0.3) -> SensorTrend:
    return SensorTrend(1, PERIOD_S, LIMIT_DEG_PER_S, PERSIST, np.array([1.0]), np.array([natural_rad_per_s]),
                       np.array([stated_noise_deg]))


def test_a_sensor_noisier_than_stated_widens_the_trend_s_doubt_as_its_noise() -> None:
    """The stated noise is a floor, not the figure: a sensor four times noisier than the
    profile says gives the trend about four times the standard error (its sample-to-sample
    differences measure it), so its noise is not read as a drift."""
    _, stated = sweep(trend_for(60.0), 0.3, 0.0, 20.0)
    _, noisier = sweep(trend_for(60.0), 1.2, 0.0, 20.0)
    ratio = float(np.median(noisier) / np.median(stated))
    assert 3.0 < ratio < 5.0, ratio


def test_a_slowly_ringing_finger_s_drift_is_caught_as_soon_as_a_stiff_one_s() -> None:
    """The low-pass's corner follows the finger's natural frequency down to a floor: a finger
    ringing at 5 rad/s is not filtered so hard that a 4 deg/s drift grows much larger
    before the fault than on a stiff finger."""
    stiff, _ = sweep(trend_for(60.0), 0.3, 4.0, 12.0)
    slow, _ = sweep(trend_for(5.0), 0.3, 4.0, 12.0)
    assert stiff is not None and slow is not None, (stiff, slow)
    assert slow < 1.25 * stiff, (slow, stiff)


def test_no_drift_no_fault() -> None:
    for natural in (5.0, 60.0):
        faulted, _ = sweep(trend_for(natural), 0.3, 0.0, 12.0, seed=3)
        assert faulted is None
