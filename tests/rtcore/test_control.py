"""Behaviour of the C step: limits, anti-windup, force estimate, NaN, modes, closed loop."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.linalg import expm

from rtcore import (
    FF_QUASI_STATIC,
    FLAG_INTEGRATOR_HELD,
    FLAG_MODE_CHANGED,
    FLAG_MODE_REJECTED,
    FLAG_RATE_LIMITED,
    FLAG_REFERENCE_REJECTED,
    FLAG_SATURATED,
    FLAG_SENSOR_REJECTED,
    MODE_FORCE,
    MODE_POSITION,
    MODE_PRESSURE,
    MODE_VENT,
    ConfigError,
    Effects,
    FingerConfig,
    Hand,
    HandConfig,
    flag_names,
)

from .conftest import mv_for_deg


def one(finger: FingerConfig, **hand: float) -> Hand:
    return Hand(HandConfig([finger], **hand))


def hold(hand: Hand, ticks: int) -> None:
    for _ in range(ticks):
        hand.step()


class ExactPlant:
    """The linear PRBM under a zero-order-hold pressure, discretised exactly."""

    def __init__(self, f: FingerConfig, dt_s: float) -> None:
        p = f.prbm
        a = np.array([[0.0, 1.0], [-p.stiffness_nm_per_rad / p.inertia_kgm2,
                                    -p.damping_nms_per_rad / p.inertia_kgm2]])
        b = np.array([[0.0], [p.pressure_gain_nm_per_kpa / p.inertia_kgm2]])
        m = expm(np.block([[a, b], [np.zeros((1, 3))]]) * dt_s)
        self.phi, self.gamma = m[:2, :2], m[:2, 2]
        self.x = np.zeros(2)

    def advance(self, pressure_kpa: float) -> float:
        self.x = self.phi @ self.x + self.gamma * pressure_kpa
        return math.degrees(self.x[0])


def test_pressure_mode_rate_limits_then_saturates(index_finger: FingerConfig) -> None:
    hand = one(index_finger)
    hand.inputs.mode[:] = MODE_PRESSURE
    hand.inputs.pressure_ref_kpa[:] = 150.0
    flags = hand.step()
    assert hand.outputs.pressure_cmd_kpa[0] == pytest.approx(20.0)  # 2000 kPa/s * 10 ms
    assert flags & FLAG_RATE_LIMITED
    hold(hand, 10)
    assert hand.outputs.pressure_cmd_kpa[0] == pytest.approx(150.0)
    hand.inputs.pressure_ref_kpa[:] = 999.0
    hold(hand, 10)
    assert hand.outputs.pressure_cmd_kpa[0] == index_finger.pressure_max_kpa
    assert hand.outputs.flags[0] & FLAG_SATURATED
    hand.inputs.pressure_ref_kpa[:] = -50.0
    hold(hand, 20)
    assert hand.outputs.pressure_cmd_kpa[0] == index_finger.pressure_min_kpa


def test_anti_windup_holds_the_integrator(index_finger: FingerConfig) -> None:
    hand = one(index_finger.replace(pressure_max_kpa=20.0, integrator_limit_kpa=1e3))
    hand.inputs.mode[:] = MODE_POSITION
    hand.inputs.sensor_mv[:] = mv_for_deg(index_finger, 0.0)
    hand.inputs.angle_ref_deg[:] = 90.0
    hold(hand, 1000)  # 10 s against the limit
    assert hand.outputs.pressure_cmd_kpa[0] == 20.0
    assert hand.outputs.flags[0] & FLAG_INTEGRATOR_HELD
    assert abs(hand.integrator_kpa(0)) < 1.0
    hand.inputs.angle_ref_deg[:] = 0.0
    hand.step()
    assert hand.outputs.pressure_cmd_kpa[0] < 20.0, "leaves saturation at once"


def test_integrator_clamped_to_its_limit(index_finger: FingerConfig) -> None:
    hand = one(index_finger.replace(integrator_limit_kpa=5.0, pressure_max_kpa=500.0,
                                    ki_kpa_per_deg_s=50.0))
    hand.inputs.mode[:] = MODE_POSITION
    hand.inputs.sensor_mv[:] = mv_for_deg(index_finger, 0.0)
    hand.inputs.angle_ref_deg[:] = 30.0
    hold(hand, 200)
    assert hand.integrator_kpa(0) == pytest.approx(5.0)


@pytest.mark.parametrize("dynamic", [0, 1])
def test_force_estimate_is_the_moore_penrose_solution(index_finger: FingerConfig, dynamic: int) -> None:
    f = index_finger.replace(force_estimate_dynamic=dynamic)
    hand = one(f)
    angle_deg, pressure_kpa = 75.0, 140.0
    hand.inputs.sensor_mv[:] = mv_for_deg(f, angle_deg)
    hand.inputs.pressure_meas_kpa[:] = pressure_kpa
    hold(hand, 300)  # at rest: velocity and acceleration estimates settle to 0
    theta = math.radians(angle_deg)
    jacobian = f.prbm.lever_arm_m * np.array([-math.sin(theta), math.cos(theta)])
    torque = f.prbm.pressure_gain_nm_per_kpa * pressure_kpa - f.prbm.stiffness_nm_per_rad * theta
    expected = np.linalg.pinv(jacobian.reshape(1, 2)) @ np.array([torque])  # (J^T)+ tau
    out = hand.outputs
    np.testing.assert_allclose([out.force_est_x_n[0], out.force_est_y_n[0]], expected, atol=1e-9)
    assert out.force_magnitude_n[0] == pytest.approx(np.linalg.norm(expected), abs=1e-9)
    assert out.force_normal_n[0] == pytest.approx(torque / f.prbm.lever_arm_m, abs=1e-9)


def test_force_estimate_without_measured_pressure_uses_the_valve_model(index_finger: FingerConfig) -> None:
    f = index_finger.replace(effects=Effects(valve_lag_tau_s=0.05))
    hand = one(f)
    hand.inputs.mode[:] = MODE_PRESSURE
    hand.inputs.pressure_ref_kpa[:] = 100.0
    hold(hand, 10)
    chamber = hand.outputs.chamber_pressure_kpa[0]
    assert 0.0 < chamber < hand.outputs.pressure_cmd_kpa[0], "lags the command"
    hold(hand, 200)
    assert hand.outputs.chamber_pressure_kpa[0] == pytest.approx(100.0, rel=1e-6)


def test_nan_sensor_is_held_and_flagged(index_finger: FingerConfig) -> None:
    hand = one(index_finger)
    hand.inputs.mode[:] = MODE_POSITION
    hand.inputs.sensor_mv[:] = mv_for_deg(index_finger, 30.0)
    hand.inputs.angle_ref_deg[:] = 30.0
    hold(hand, 100)
    before = hand.outputs.angle_filt_deg[0]
    for bad in (np.nan, np.inf, -np.inf, 1e300):
        hand.inputs.sensor_mv[:] = bad
        flags = hand.step()
        assert flags & FLAG_SENSOR_REJECTED, flag_names(flags)
        assert hand.outputs.angle_deg[0] == pytest.approx(30.0)
        assert hand.outputs.angle_filt_deg[0] == pytest.approx(before, abs=1e-6)
        assert np.isfinite(hand.outputs.pressure_cmd_kpa[0])
    hand.inputs.sensor_mv[:] = mv_for_deg(index_finger, 30.0)
    assert not hand.step() & FLAG_SENSOR_REJECTED


def test_nan_reference_is_held_and_flagged(index_finger: FingerConfig) -> None:
    hand = one(index_finger)
    hand.inputs.mode[:] = MODE_POSITION
    hand.inputs.sensor_mv[:] = mv_for_deg(index_finger, 10.0)
    hand.inputs.angle_ref_deg[:] = 10.0
    hold(hand, 50)
    command = hand.outputs.pressure_cmd_kpa[0]
    hand.inputs.angle_ref_deg[:] = np.nan
    assert hand.step() & FLAG_REFERENCE_REJECTED
    assert hand.outputs.pressure_cmd_kpa[0] == pytest.approx(command, abs=0.1)
    hand.inputs.mode[:] = MODE_VENT  # vent uses no reference: nothing to flag
    assert not hand.step() & FLAG_REFERENCE_REJECTED


def test_vent_is_immediate_and_unknown_modes_vent(index_finger: FingerConfig) -> None:
    hand = one(index_finger)
    hand.inputs.mode[:] = MODE_PRESSURE
    hand.inputs.pressure_ref_kpa[:] = 100.0
    hold(hand, 20)
    hand.inputs.mode[:] = MODE_VENT
    assert hand.step() & FLAG_MODE_CHANGED
    assert hand.outputs.pressure_cmd_kpa[0] == 0.0
    hand.inputs.mode[:] = 17
    assert hand.step() & FLAG_MODE_REJECTED
    assert hand.outputs.pressure_cmd_kpa[0] == 0.0


@pytest.mark.parametrize(("first", "second"), [(MODE_PRESSURE, MODE_POSITION),
                                               (MODE_POSITION, MODE_FORCE),
                                               (MODE_FORCE, MODE_POSITION)])
def test_switching_between_active_modes_is_bumpless(index_finger: FingerConfig, first: int,
                                                    second: int) -> None:
    hand = one(index_finger)
    hand.inputs.sensor_mv[:] = mv_for_deg(index_finger, 25.0)
    hand.inputs.mode[:] = first
    hand.inputs.pressure_ref_kpa[:] = 70.0
    hand.inputs.angle_ref_deg[:] = 40.0
    hand.inputs.force_ref_n[:] = 0.5
    hold(hand, 50)
    before = hand.outputs.pressure_cmd_kpa[0]
    hand.inputs.mode[:] = second
    assert hand.step() & FLAG_MODE_CHANGED
    out = hand.outputs
    # the command may move by one tick of integral action, never by the step in ff + P
    if second == MODE_POSITION:
        one_tick = index_finger.ki_kpa_per_deg_s * abs(40.0 - out.angle_filt_deg[0]) * 0.01
    else:
        one_tick = index_finger.force_ki_kpa_per_n_s * abs(0.5 - out.force_normal_n[0]) * 0.01
    jump = abs(out.pressure_cmd_kpa[0] - before)
    assert jump <= one_tick + 1e-9, f"command jumped {jump:.3f} kPa (one tick is {one_tick:.3f})"
    assert abs(hand.integrator_kpa(0)) > 3.0, "the integrator took up a real difference"


def test_reset_returns_to_vent(index_finger: FingerConfig) -> None:
    hand = one(index_finger)
    hand.inputs.mode[:] = MODE_PRESSURE
    hand.inputs.pressure_ref_kpa[:] = 80.0
    hold(hand, 20)
    hand.reset()
    assert hand.ticks == 0
    hand.inputs.mode[:] = MODE_VENT
    hand.step()
    assert hand.outputs.pressure_cmd_kpa[0] == 0.0


@pytest.mark.parametrize("feedforward", [FF_QUASI_STATIC, 2])
def test_closed_loop_reaches_and_holds_a_setpoint(index_finger: FingerConfig, feedforward: int) -> None:
    f = index_finger.replace(feedforward=feedforward)
    hand = one(f)
    plant = ExactPlant(f, 0.01)
    hand.inputs.mode[:] = MODE_POSITION
    hand.inputs.angle_ref_deg[:] = 60.0
    angle = 0.0
    errors = []
    for _ in range(600):
        hand.inputs.sensor_mv[:] = mv_for_deg(f, angle)
        hand.step()
        angle = plant.advance(hand.outputs.pressure_cmd_kpa[0])
        errors.append(angle - 60.0)
    assert max(abs(e) for e in errors[400:]) < 0.05, "holds within 0.05 deg"


def test_closed_loop_force_control_presses_as_asked(index_finger: FingerConfig) -> None:
    """Against a damped contact spring past 40 deg, force mode settles on the asked force."""
    f = index_finger
    hand = one(f)
    dt, contact_rad, contact_k, contact_c = 0.01, math.radians(40.0), 2.0, 0.04
    theta = omega = 0.0
    hand.inputs.mode[:] = MODE_FORCE
    hand.inputs.force_ref_n[:] = 1.2

    def accel(th: float, om: float, p: float) -> float:
        m = f.prbm
        torque = m.pressure_gain_nm_per_kpa * p - m.stiffness_nm_per_rad * th - m.damping_nms_per_rad * om
        if th > contact_rad:
            torque -= contact_k * (th - contact_rad) + contact_c * om
        return torque / m.inertia_kgm2

    for _ in range(800):
        hand.inputs.sensor_mv[:] = mv_for_deg(f, math.degrees(theta))
        hand.step()
        p = hand.outputs.pressure_cmd_kpa[0]
        for _ in range(20):  # semi-implicit Euler at 0.5 ms is ample for this check
            omega += accel(theta, omega, p) * dt / 20
            theta += omega * dt / 20
    true_force = contact_k * (theta - contact_rad) / f.prbm.lever_arm_m
    assert true_force == pytest.approx(1.2, abs=0.01)
    assert hand.outputs.force_normal_n[0] == pytest.approx(1.2, abs=0.01)


def test_configure_refuses_bad_values_with_a_clear_message(index_finger: FingerConfig) -> None:
    with pytest.raises(ConfigError, match="finger 0: filter order"):
        one(index_finger.replace(filter_order=3))
    with pytest.raises(ConfigError, match="pressure limits"):
        one(index_finger.replace(pressure_min_kpa=10.0, pressure_max_kpa=0.0))
    with pytest.raises(ConfigError, match="1 to 8 fingers"):
        Hand(HandConfig([index_finger] * 9))
