"""Impedance mode: the C step and the Python reference agree to 1e-9 with it in the mix,
its gains are checked like references, a slow push in simulation meets the set
stiffness within 10 % over a 10x range, and the API's gain limits keep the loop stable."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hand_service.api.impedance import gain_limits
from hand_service.config.profile import load_profile
from hand_service.pinch.compliance import free_step, miscalibrated, slow_push
from rtcore import (
    FLAG_REFERENCE_REJECTED,
    MODE_IMPEDANCE,
    FingerConfig,
    Hand,
    HandConfig,
    ReferenceHand,
)
from rtcore.arrays import Outputs, field_names
from tests.rtcore.conftest import mv_for_deg
from tests.rtcore.test_equivalence import SPECIALS, hand_strategy

TICKS = 200
# Virtual damping acts on a filtered, lagged velocity: the API allows up to about 0.001
# N s/deg (hand_service.api.impedance); the push test runs well inside it.
DAMPING_N_S_PER_DEG = 0.0003


def drive(hand: Hand | ReferenceHand, config: HandConfig, seed: int) -> list[dict[str, np.ndarray]]:
    """Mostly impedance mode, switched with the others now and then; gains random, some
    negative, NaN or Inf; references with the same sprinkling of absurd values."""
    rng = np.random.default_rng(seed)
    n = config.n_fingers
    gains = np.array([f.sensor_gain_deg_per_mv for f in config.fingers])
    offsets = np.array([f.sensor_offset_deg for f in config.fingers])
    mode = np.full(n, MODE_IMPEDANCE)
    history = []
    for tick in range(TICKS):
        t = tick / config.sample_rate_hz
        angle = 40.0 + 30.0 * np.sin(2 * np.pi * rng.uniform(0.5, 3.0, n) * t) + rng.normal(0, 1, n)
        switch = rng.random(n) < 0.05
        mode = np.where(switch, np.where(rng.random(n) < 0.5, MODE_IMPEDANCE, rng.integers(-1, 6, n)), mode)
        inputs = {
            "sensor_mv": (angle - offsets) / gains,
            "pressure_meas_kpa": np.where(rng.random(n) < 0.5, rng.uniform(-5, 220, n), np.nan),
            "mode": mode.astype(np.int32),
            "angle_ref_deg": rng.uniform(-10, 120, n),
            "velocity_ref_deg_per_s": rng.normal(0, 100, n),
            "accel_ref_deg_per_s2": rng.normal(0, 1000, n),
            "jerk_ref_deg_per_s3": rng.normal(0, 10000, n),
            "force_ref_n": rng.uniform(-0.5, 3.0, n),
            "pressure_ref_kpa": rng.uniform(-20, 300, n),
            "impedance_stiffness_n_per_deg": rng.uniform(-0.01, 0.3, n),
            "impedance_damping_n_s_per_deg": rng.uniform(-0.001, 0.01, n),
        }
        for name, values in inputs.items():
            if name != "mode":
                bad = rng.random(n) < 0.02
                values[bad] = rng.choice(SPECIALS, bad.sum())
        for name, values in inputs.items():
            getattr(hand.inputs, name)[:] = values
        hand.step()
        history.append({name: getattr(hand.outputs, name).copy() for name in field_names(Outputs)})
    return history


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow], derandomize=True)
@given(config=hand_strategy, seed=st.integers(0, 2**32 - 1))
def test_c_matches_reference_in_impedance_mode(config: HandConfig, seed: int) -> None:
    c_hist = drive(Hand(config), config, seed)
    py_hist = drive(ReferenceHand(config), config, seed)
    for tick, (c_out, py_out) in enumerate(zip(c_hist, py_hist, strict=True)):
        np.testing.assert_array_equal(c_out["flags"], py_out["flags"], err_msg=f"flags, tick {tick}")
        for name in field_names(Outputs):
            if name != "flags":
                scale = np.maximum(1.0, np.abs(py_out[name]))
                worst = np.max(np.abs(c_out[name] - py_out[name]) / scale)
                assert worst <= 1e-9, f"{name} differs by {worst:.3g} (relative) at tick {tick}"


@pytest.mark.parametrize("kind", [Hand, ReferenceHand])
def test_impedance_is_force_control_on_a_virtual_spring(index_finger: FingerConfig, kind: type) -> None:
    """Held 10 deg short of its reference, the finger is asked for K * 10 deg of force: the
    feedforward is the force feedforward of that force, and a bad gain is held and flagged."""
    config = HandConfig([index_finger, index_finger])
    hand = kind(config)
    hand.inputs.sensor_mv[:] = mv_for_deg(index_finger, 30.0)
    hand.inputs.angle_ref_deg[:] = 40.0
    hand.inputs.impedance_stiffness_n_per_deg[:] = 0.05
    hand.inputs.mode[0] = MODE_IMPEDANCE
    hand.inputs.mode[1] = 3  # force mode, asked for the same 0.5 N directly
    hand.inputs.force_ref_n[1] = 0.5
    for _ in range(50):
        hand.step()
    ff = np.array(hand.outputs.feedforward_kpa)
    assert ff[0] == pytest.approx(ff[1], rel=1e-12)
    hand.inputs.impedance_stiffness_n_per_deg[0] = -1.0
    assert hand.step() & FLAG_REFERENCE_REJECTED
    assert hand.outputs.feedforward_kpa[0] == pytest.approx(ff[0], rel=1e-12)  # the last good K held
    hand.inputs.impedance_stiffness_n_per_deg[0] = np.nan
    hand.step()
    assert hand.outputs.flags[0] & FLAG_REFERENCE_REJECTED


@pytest.mark.parametrize("finger", ["index", "middle", "little"])
def test_a_slow_push_meets_the_set_stiffness_over_a_tenfold_range(finger: str) -> None:
    """K from a tenth of the finger's stable limit to the limit (docs/replicate.md)."""
    profile = load_profile(None)
    k_max, _ = gain_limits(profile.finger(finger).model)
    for share in (0.1, 0.3, 1.0):  # a factor 10
        stiffness = share * k_max
        push = slow_push(profile, finger, stiffness, DAMPING_N_S_PER_DEG)
        assert abs(push.error_ratio) < 0.10, (
            f"{finger}: set {stiffness:.4f} N/deg, measured {push.measured_stiffness_n_per_deg:.4f} N/deg")
        assert push.force_n.max() > 50 * stiffness  # the push went at least 50 deg deep


@pytest.mark.parametrize("finger", ["thumb", "middle", "ring"])
def test_the_gain_limits_leave_the_free_finger_stable_and_have_a_margin(finger: str) -> None:
    """At K_max and D_max a free finger settles on a 10 deg reference step (noise: 0.3 deg);
    at three times K_max it does not: the limits are not arbitrary, and they keep a margin."""
    profile = load_profile(None)
    k_max, d_max = gain_limits(profile.finger(finger).model)
    assert free_step(profile, finger, k_max, 0.0) < 2.0
    assert free_step(profile, finger, k_max, d_max) < 2.0
    assert free_step(profile, finger, 3.0 * k_max, 0.0) > 10.0
    assert free_step(profile, finger, k_max, 4.0 * d_max) > 10.0


def test_a_miscalibrated_model_shifts_the_stiffness_as_the_estimate_predicts() -> None:
    """With k 2 % high and N 2 % low in the controller's model, the estimate's bias is
    F·e + 2·e·k·θ/r: the measured stiffness is (K − 4·e·K_max)/(1 − e) (docs/replicate.md)."""
    truth = load_profile(None)
    error = 0.02
    k_max, _ = gain_limits(truth.finger("index").model)
    controller = miscalibrated(truth, 100 * error)
    for share in (0.3, 1.0):
        push = slow_push(truth, "index", share * k_max, 0.0, controller=controller)
        predicted = (share * k_max - 4 * error * k_max) / (1 - error)
        assert push.measured_stiffness_n_per_deg == pytest.approx(predicted, rel=0.03), share


@pytest.mark.slow
def test_with_the_lab_measured_model_the_compliance_holds_over_a_tenfold_range() -> None:
    """The controller knows the hand as replicate's lab measured it (10 releases a finger),
    not the truth: every finger within 10 % from a tenth of its limit to the limit."""
    from hand_service.replicate.pinch_run import measured_controller

    truth, controller = measured_controller(None, 1, 10)
    for f in truth.fingers:
        k_max, _ = gain_limits(controller.finger(f.name).model)
        for share in (0.1, 0.3, 1.0):
            push = slow_push(truth, f.name, share * k_max, 0.0, controller=controller)
            assert abs(push.error_ratio) < 0.10, (f.name, share, push.error_ratio)

