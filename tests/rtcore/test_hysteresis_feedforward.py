"""The position feedforward's copy of the finger's hysteresis loop (csrc/rtcore_model.c,
rtcore_hysteresis_reference_update): H·z added to the torque, z Dahl's state driven by the
angle reference led by the valve lag + dead time, at its middle on entering position mode.
Two hands alike but for the loop, fed the same references: their feedforwards differ by
H·z/N, z as Dahl's closed form gives it over the path."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rtcore import FF_QUASI_STATIC, MODE_POSITION, ConfigError, Effects, FingerConfig, Hand, HandConfig

from .conftest import mv_for_deg

TORQUE_NM = 0.02
TRAVEL_DEG = 2.0


def hand(finger: FingerConfig, **effects: float) -> Hand:
    return Hand(HandConfig([finger.replace(feedforward=FF_QUASI_STATIC, effects=Effects(**effects))]))


def feedforward_kpa(finger: FingerConfig, path: list[tuple[float, float]], **effects: float) -> np.ndarray:
    """The feedforward at every tick of `path` (angle_ref_deg, velocity_ref_deg_per_s), the
    finger read at 0° throughout."""
    h = hand(finger, **effects)
    out = []
    for angle_deg, velocity_deg_per_s in path:
        h.inputs.mode[0] = MODE_POSITION
        h.inputs.sensor_mv[0] = mv_for_deg(finger, 0.0)
        h.inputs.angle_ref_deg[0] = angle_deg
        h.inputs.velocity_ref_deg_per_s[0] = velocity_deg_per_s
        h.step()
        out.append(float(h.outputs.feedforward_kpa[0]))
    return np.array(out)


def dahl(z: float, travel_deg: float) -> float:
    toward = math.copysign(1.0, travel_deg)
    return toward + (z - toward) * math.exp(-abs(travel_deg) / TRAVEL_DEG)


def test_the_loop_follows_the_reference_as_dahl_has_it(index_finger: FingerConfig) -> None:
    """Up 0° → 30° in 1° ticks, then back to 24°: z from 0 by Dahl's closed form."""
    up = [(float(a), 0.0) for a in range(0, 31)]
    down = [(float(a), 0.0) for a in range(29, 23, -1)]
    loop = {"hysteresis_torque_nm": TORQUE_NM, "hysteresis_travel_deg": TRAVEL_DEG}
    difference = feedforward_kpa(index_finger, up + down, **loop) - feedforward_kpa(index_finger, up + down)
    expected, z, last = [], 0.0, 0.0  # entered at the filtered angle, 0°, the loop at its middle
    for angle_deg, _ in up + down:
        if angle_deg != last:
            z = dahl(z, angle_deg - last)
        last = angle_deg
        expected.append(TORQUE_NM * z / index_finger.prbm.pressure_gain_nm_per_kpa)
    np.testing.assert_allclose(difference, expected, rtol=1e-9, atol=1e-12)
    assert difference[30] > 0.99 * TORQUE_NM / index_finger.prbm.pressure_gain_nm_per_kpa  # rising: +H
    assert difference[-1] < -0.85 * TORQUE_NM / index_finger.prbm.pressure_gain_nm_per_kpa  # turned: −H


def test_the_loop_turns_a_lead_ahead_of_the_reference(index_finger: FingerConfig) -> None:
    """With a valve lag and a dead time, a reference about to turn (its velocity negative)
    turns the loop already: z is driven at θ_ref + (τ + delay)·θ'_ref."""
    lead_s = 0.03 + 0.01
    path = [(float(a), 100.0) for a in range(0, 31)] + [(30.0, -100.0)]
    loop = {"hysteresis_torque_nm": TORQUE_NM, "hysteresis_travel_deg": TRAVEL_DEG}
    lag = {"valve_lag_tau_s": 0.03, "dead_time_s": 0.01}
    difference = (feedforward_kpa(index_finger, path, **loop, **lag)
                  - feedforward_kpa(index_finger, path, **lag))
    led_before, led_now = 30.0 + lead_s * 100.0, 30.0 - lead_s * 100.0
    z_before = difference[-2] * index_finger.prbm.pressure_gain_nm_per_kpa / TORQUE_NM
    z_now = difference[-1] * index_finger.prbm.pressure_gain_nm_per_kpa / TORQUE_NM
    assert z_before > 0.99
    assert z_now == pytest.approx(dahl(z_before, led_now - led_before), rel=1e-9)
    assert z_now < 0.0


@pytest.mark.parametrize("effects", [{"hysteresis_torque_nm": math.nan},
                                     {"hysteresis_torque_nm": math.inf},
                                     {"hysteresis_torque_nm": -0.01},
                                     {"hysteresis_torque_nm": 0.01, "hysteresis_travel_deg": 0.0},
                                     {"hysteresis_torque_nm": 0.01, "hysteresis_travel_deg": math.nan}])
def test_a_loop_that_is_not_a_loop_is_refused(index_finger: FingerConfig, effects: dict[str, float]) -> None:
    with pytest.raises(ConfigError, match="effects"):
        hand(index_finger, **effects)
