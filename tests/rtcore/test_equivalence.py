"""The C step and the pure-Python reference agree to 1e-9 on random hands and inputs."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rtcore import Effects, FingerConfig, Hand, HandConfig, Prbm, ReferenceHand
from rtcore.arrays import Outputs, field_names

TICKS_PER_EXAMPLE = 200
EXAMPLES = 25  # make test's share, the same hands every run (5,000 ticks)
FUZZ_EXAMPLES = 400  # `make fuzz`: new hands every run (80,000 ticks)


def positive(lo: float, hi: float) -> st.SearchStrategy[float]:
    return st.floats(lo, hi, allow_nan=False, allow_infinity=False)


def maybe(strategy: st.SearchStrategy[float]) -> st.SearchStrategy[float]:
    return st.one_of(st.just(0.0), strategy)


effects_strategy = st.builds(
    Effects,
    valve_lag_tau_s=maybe(positive(0.005, 0.1)),
    valve_vent_tau_s=maybe(positive(0.005, 0.4)),
    dead_time_s=maybe(positive(0.001, 0.05)),
    coulomb_torque_nm=maybe(positive(1e-4, 0.01)),
    coulomb_smoothing_deg_per_s=positive(0.5, 20.0),
    cubic_stiffness_nm_per_rad3=maybe(positive(-0.05, 0.2)),
    gravity_torque_nm=maybe(positive(0.0, 0.02)),
    asymmetric_stiffness_ratio=st.one_of(st.just(1.0), positive(0.3, 3.0)),
    quadratic_damping_nms2_per_rad2=maybe(positive(1e-6, 1e-3)),
    pressure_deadzone_kpa=maybe(positive(0.5, 20.0)),
    contact_stiffness_nm_per_radn=maybe(positive(0.05, 5.0)),
    contact_onset_deg=positive(-10.0, 60.0),
    contact_exponent=positive(1.0, 3.0),
    contact_damping_nms_per_rad=maybe(positive(1e-4, 0.05)),
    pressure_stiffening_gain=maybe(positive(0.05, 3.0)),
    pressure_stiffening_ref_kpa=positive(20.0, 200.0),
    creep_stiffness_ratio=maybe(positive(0.01, 2.0)),
    creep_time_s=positive(0.05, 5.0),
    hysteresis_torque_nm=maybe(positive(1e-4, 0.05)),
    hysteresis_travel_deg=positive(0.1, 30.0),
)


@st.composite
def finger_strategy(draw: st.DrawFn) -> FingerConfig:
    pressure_min = draw(st.one_of(st.just(0.0), positive(-20.0, 20.0)))
    prbm = Prbm(
        inertia_kgm2=draw(positive(5e-5, 3e-4)),
        damping_nms_per_rad=draw(positive(0.0, 0.01)),
        stiffness_nm_per_rad=draw(positive(0.2, 1.0)),
        pressure_gain_nm_per_kpa=draw(positive(4e-3, 2e-2)),
        lever_arm_m=draw(positive(0.02, 0.06)),
    )
    sensor_and_filters = dict(
        sensor_gain_deg_per_mv=draw(st.one_of(positive(0.02, 0.5), positive(-0.5, -0.02))),
        sensor_offset_deg=draw(positive(-50.0, 50.0)),
        filter_order=draw(st.sampled_from([2, 4])),
        filter_cutoff_hz=draw(positive(1.0, 45.0)),
        velocity_cutoff_hz=draw(positive(1.0, 60.0)),
    )
    prbm.effects = draw(effects_strategy)  # drawn in its old place: the same derandomized examples
    return FingerConfig(
        prbm=prbm,
        **sensor_and_filters,
        feedforward=draw(st.sampled_from([0, 1, 2])),
        force_estimate_dynamic=draw(st.sampled_from([0, 1])),
        force_estimate_hysteresis=draw(st.sampled_from([0, 1])),
        kp_kpa_per_deg=draw(positive(0.0, 2.0)),
        ki_kpa_per_deg_s=draw(positive(0.0, 10.0)),
        kd_kpa_s_per_deg=draw(positive(0.0, 0.05)),
        derivative_cutoff_hz=draw(positive(1.0, 40.0)),
        integrator_limit_kpa=draw(positive(0.0, 100.0)),
        force_kp_kpa_per_n=draw(positive(0.0, 10.0)),
        force_ki_kpa_per_n_s=draw(positive(0.0, 50.0)),
        pressure_min_kpa=pressure_min,
        pressure_max_kpa=pressure_min + draw(positive(10.0, 250.0)),
        pressure_rate_max_kpa_per_s=draw(positive(100.0, 5000.0)),
    )


hand_strategy = st.builds(
    HandConfig,
    fingers=st.lists(finger_strategy(), min_size=1, max_size=8),
    sample_rate_hz=st.sampled_from([100.0, 200.0, 500.0, 1000.0]),
)

SPECIALS = np.array([np.nan, np.inf, -np.inf, 1e300, -1e300, 2e6])


def drive(hand: Hand | ReferenceHand, config: HandConfig, seed: int) -> list[dict[str, np.ndarray]]:
    """Random but plausible inputs: angles swept by a sine, modes switched now and then,
    and a sprinkling of NaN, Inf and absurd values."""
    rng = np.random.default_rng(seed)
    n = config.n_fingers
    mode = rng.integers(0, 4, n)
    history = []
    for tick in range(TICKS_PER_EXAMPLE):
        t = tick / config.sample_rate_hz
        angle = 40.0 + 35.0 * np.sin(2 * np.pi * rng.uniform(0.5, 3.0, n) * t) + rng.normal(0, 1, n)
        gains = np.array([f.sensor_gain_deg_per_mv for f in config.fingers])
        offsets = np.array([f.sensor_offset_deg for f in config.fingers])
        switch = rng.random(n) < 0.03
        mode = np.where(switch, rng.integers(-1, 5, n), mode)
        inputs = {
            "sensor_mv": (angle - offsets) / gains,
            "pressure_meas_kpa": np.where(rng.random(n) < 0.5, rng.uniform(-5, 220, n), np.nan),
            "mode": mode.astype(np.int32),
            "angle_ref_deg": rng.uniform(-10, 120, n),
            "velocity_ref_deg_per_s": rng.normal(0, 200, n),
            "accel_ref_deg_per_s2": rng.normal(0, 2000, n),
            "jerk_ref_deg_per_s3": rng.normal(0, 20000, n),
            "force_ref_n": rng.uniform(-0.5, 3.0, n),
            "pressure_ref_kpa": rng.uniform(-20, 300, n),
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


def agree(config: HandConfig, seed: int) -> None:
    c_hist = drive(Hand(config), config, seed)
    py_hist = drive(ReferenceHand(config), config, seed)
    for tick, (c_out, py_out) in enumerate(zip(c_hist, py_hist, strict=True)):
        np.testing.assert_array_equal(c_out["flags"], py_out["flags"], err_msg=f"flags, tick {tick}")
        for name in field_names(Outputs):
            if name == "flags":
                continue
            scale = np.maximum(1.0, np.abs(py_out[name]))
            worst = np.max(np.abs(c_out[name] - py_out[name]) / scale)
            assert worst <= 1e-9, f"{name} differs by {worst:.3g} (relative) at tick {tick}"


@settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=[HealthCheck.too_slow],
          derandomize=True)
@given(config=hand_strategy, seed=st.integers(0, 2**32 - 1))
def test_c_matches_reference(config: HandConfig, seed: int) -> None:
    agree(config, seed)


@pytest.mark.fuzz
@settings(max_examples=FUZZ_EXAMPLES, deadline=None, suppress_health_check=[HealthCheck.too_slow],
          database=None)
@given(config=hand_strategy, seed=st.integers(0, 2**32 - 1))
def test_c_matches_reference_on_new_hands(config: HandConfig, seed: int) -> None:
    agree(config, seed)


def test_reference_state_fields_cover_c_state() -> None:
    """Every running-state field of the C finger state has its twin in the reference."""
    from rtcore._rtcore import ffi
    from rtcore.reference import FingerState

    c_fields = {name for name, _ in ffi.typeof("rtcore_finger_state").fields}
    py_fields = {f.name for f in dataclasses.fields(FingerState)}
    derived_in_c_only = {"section", "n_sections"}
    assert c_fields - derived_in_c_only <= py_fields | {"sections"}
