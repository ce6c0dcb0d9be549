"""Default PI gains from a finger's own model, by gain margin.

The fingers are lightly damped (ζ 0.06–0.16) and ring at 9–14 Hz, right where the valve
lag, the dead time, the sample hold and the Butterworth filter have eaten the phase, so
a gain that suits one finger makes another oscillate. The rule here: compute the open
loop from the PI output to the filtered angle,

    L(jω) = C(z) · (180/π)·N / (A s² + B s + k) · e^(−s·delay) / (τ s + 1)
            · e^(−sT/2)·sinc(fT) · F(z),        C(z) = kp·(1 + ω_i·T·z/(z − 1)),

find where its phase reaches −180°, and choose kp so that the loop gain there is
1/GAIN_MARGIN; ki = ω_i·kp. The linear model predicts the simulator's critical gains to
three digits for every default finger (tests/config/test_tuning.py checks the margin in
closed loop). A valve that vents with a lag of its own (the valve_vent_lag effect) is
not linear; τ is then the geometric mean of the fill's and the vent's lags
(valve_lag_s), which predicts the simulator's critical gain far closer than the fill's
lag alone (docs/results.md §12.35).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np

import rtcore

GAIN_MARGIN = 3.0
INTEGRAL_RATE_PER_S = 10.0  # ki = 10/s · kp: integral action well below the resonance


@dataclass(frozen=True)
class Gains:
    kp_kpa_per_deg: float
    ki_kpa_per_deg_s: float
    critical_kp_kpa_per_deg: float
    phase_crossover_hz: float


def sos_response(sos: np.ndarray, z: np.ndarray) -> np.ndarray:
    """The second-order sections' response at z (scipy's sosfreqz, without importing
    scipy.signal, whose import every process that reads a profile would pay)."""
    zi = 1.0 / z
    response = np.ones_like(z)
    for b0, b1, b2, a0, a1, a2 in sos:
        response = response * (b0 + zi * (b1 + zi * b2)) / (a0 + zi * (a1 + zi * a2))
    return response


def valve_lag_s(effects: rtcore.Effects) -> float:
    """The valve's lag in the linear loop: the fill's, or with a vent lag of its own the
    geometric mean of the two (see the module's docstring)."""
    if effects.valve_vent_tau_s > 0.0:
        return math.sqrt(effects.valve_lag_tau_s * effects.valve_vent_tau_s)
    return effects.valve_lag_tau_s


def loop_per_kp(finger: rtcore.FingerConfig, sample_rate_hz: float, freqs_hz: np.ndarray,
                integral_rate_per_s: float = INTEGRAL_RATE_PER_S) -> np.ndarray:
    """L(jω)/kp: deg of filtered angle per deg of error, at each frequency."""
    dt_s = 1.0 / sample_rate_hz
    s = 2j * np.pi * freqs_hz
    z = np.exp(s * dt_s)
    m = finger.prbm
    prbm = math.degrees(1.0) * m.pressure_gain_nm_per_kpa / (
        m.inertia_kgm2 * s**2 + m.damping_nms_per_rad * s + m.stiffness_nm_per_rad)
    valve = np.exp(-s * m.effects.dead_time_s) / (valve_lag_s(m.effects) * s + 1.0)
    hold = np.exp(-s * dt_s / 2.0) * np.sinc(freqs_hz * dt_s)
    sos = rtcore.butter_design(finger.filter_order, finger.filter_cutoff_hz, sample_rate_hz)
    butter = sos_response(sos, z)
    pi = 1.0 + integral_rate_per_s * dt_s * z / (z - 1.0)
    return prbm * valve * hold * butter * pi


def margin_gains(finger: rtcore.FingerConfig, sample_rate_hz: float,
                 gain_margin: float = GAIN_MARGIN,
                 integral_rate_per_s: float = INTEGRAL_RATE_PER_S) -> Gains:
    """The gains for this margin. Only the model, the valve, the filter and the rate enter
    loop_per_kp, so the result is kept for those (a profile loads in ms, not 90 ms, the
    second time: tests, the fuzz tests and `include:` load the same hand again and again)."""
    m, fx = finger.prbm, finger.prbm.effects
    return _margin_gains(m.inertia_kgm2, m.damping_nms_per_rad, m.stiffness_nm_per_rad,
                         m.pressure_gain_nm_per_kpa, fx.dead_time_s, valve_lag_s(fx),
                         finger.filter_order, finger.filter_cutoff_hz, sample_rate_hz, gain_margin,
                         integral_rate_per_s)


@functools.lru_cache(maxsize=256)
def _margin_gains(inertia_kgm2: float, damping_nms_per_rad: float, stiffness_nm_per_rad: float,
                  pressure_gain_nm_per_kpa: float, dead_time_s: float, valve_lag_tau_s: float,
                  filter_order: int, filter_cutoff_hz: float, sample_rate_hz: float, gain_margin: float,
                  integral_rate_per_s: float) -> Gains:
    effects = rtcore.Effects(dead_time_s=dead_time_s, valve_lag_tau_s=valve_lag_tau_s)
    finger = rtcore.FingerConfig(
        prbm=rtcore.Prbm(inertia_kgm2, damping_nms_per_rad, stiffness_nm_per_rad, pressure_gain_nm_per_kpa,
                         0.0, effects),
        filter_order=filter_order, filter_cutoff_hz=filter_cutoff_hz)
    freqs = np.linspace(0.01, 0.499 * sample_rate_hz, 40000)
    loop = loop_per_kp(finger, sample_rate_hz, freqs, integral_rate_per_s)
    phase = np.unwrap(np.angle(loop))
    crossing = np.flatnonzero(phase <= -np.pi)
    # never reaching -180 deg below Nyquist, the peak gain bounds kp instead
    k = int(crossing[0]) if crossing.size else int(np.argmax(np.abs(loop)))
    magnitude = float(np.abs(loop[k]))
    critical = 1.0 / magnitude if magnitude > 0.0 else math.inf  # a loop with no gain: no bound
    kp = critical / gain_margin
    return Gains(kp, integral_rate_per_s * kp, critical, float(freqs[k]))
