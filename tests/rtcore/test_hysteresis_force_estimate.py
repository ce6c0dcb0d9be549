"""The force estimate's and the force feedforward's copy of the finger's hysteresis loop
(csrc/rtcore_model.c, rtcore_hysteresis_angle_update): H·z taken off the estimate's torque
and added to the force feedforward's, z Dahl's state driven by the filtered angle from the
first angle seen. Two hands alike but for the loop, fed the same sensor path in force mode:
their estimates differ by −H·z/r and their feedforwards by H·z/N."""

from __future__ import annotations

import math

import numpy as np

from rtcore import FF_QUASI_STATIC, MODE_FORCE, Effects, FingerConfig, Hand, HandConfig

from .conftest import mv_for_deg

TORQUE_NM = 0.02
TRAVEL_DEG = 2.0
PRESSURE_KPA = 40.0


def run(finger: FingerConfig, path_deg: list[float], loop_in_force: int = 1,
        **effects: float) -> dict[str, np.ndarray]:
    """Per tick of path_deg (the sensor's angle): the filtered angle, the estimate, the
    feedforward; loop_in_force the config's force_estimate_hysteresis."""
    h = Hand(HandConfig([finger.replace(feedforward=FF_QUASI_STATIC, force_estimate_dynamic=0,
                                        force_estimate_hysteresis=loop_in_force,
                                        effects=Effects(**effects))]))
    out: dict[str, list[float]] = {"angle": [], "force": [], "feedforward": []}
    for angle_deg in path_deg:
        h.inputs.mode[0] = MODE_FORCE
        h.inputs.force_ref_n[0] = 0.3
        h.inputs.sensor_mv[0] = mv_for_deg(finger, angle_deg)
        h.inputs.pressure_meas_kpa[0] = PRESSURE_KPA
        h.step()
        out["angle"].append(float(h.outputs.angle_filt_deg[0]))
        out["force"].append(float(h.outputs.force_normal_n[0]))
        out["feedforward"].append(float(h.outputs.feedforward_kpa[0]))
    return {k: np.array(v) for k, v in out.items()}


def dahl_path(angle_deg: np.ndarray) -> np.ndarray:
    """Dahl's closed form over the filtered angle's travel, from z = 0 at the first angle."""
    z, last, out = 0.0, float(angle_deg[0]), []
    for a in angle_deg:
        travel = float(a) - last
        if travel != 0.0:
            toward = math.copysign(1.0, travel)
            z = toward + (z - toward) * math.exp(-abs(travel) / TRAVEL_DEG)
        last = float(a)
        out.append(z)
    return np.array(out)


def test_the_estimate_takes_the_loop_off_and_the_feedforward_adds_it(index_finger: FingerConfig) -> None:
    """Sensor up 20° → 50° and back to 35°: the loop's torque ±H as the filtered angle turns."""
    path = [20.0] * 20 + list(np.linspace(20.0, 50.0, 60)) + list(np.linspace(50.0, 35.0, 40))
    loop = {"hysteresis_torque_nm": TORQUE_NM, "hysteresis_travel_deg": TRAVEL_DEG}
    with_loop, plain = run(index_finger, path, **loop), run(index_finger, path)
    np.testing.assert_array_equal(with_loop["angle"], plain["angle"])
    z = dahl_path(with_loop["angle"])
    r, n = index_finger.prbm.lever_arm_m, index_finger.prbm.pressure_gain_nm_per_kpa
    np.testing.assert_allclose(with_loop["force"] - plain["force"], -TORQUE_NM * z / r, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(with_loop["feedforward"] - plain["feedforward"], TORQUE_NM * z / n,
                               rtol=1e-9, atol=1e-12)
    assert z[79] > 0.99  # bending: the loop resists with +H
    assert z[-1] < -0.95  # turned back over 15°: −H


def test_without_the_loop_nothing_changes(index_finger: FingerConfig) -> None:
    """A hand whose model has no loop keeps the estimate N·p − τ over r, whatever the path."""
    path = list(np.linspace(0.0, 40.0, 50)) + list(np.linspace(40.0, 10.0, 50))
    plain = run(index_finger, path)
    m = index_finger.prbm
    angle_rad = np.radians(plain["angle"])
    torque_nm = m.pressure_gain_nm_per_kpa * PRESSURE_KPA - m.stiffness_nm_per_rad * angle_rad
    expected = torque_nm / m.lever_arm_m
    np.testing.assert_allclose(plain["force"], expected, rtol=1e-9, atol=1e-12)


def test_the_loop_stays_out_of_force_unless_asked(index_finger: FingerConfig) -> None:
    """force_estimate_hysteresis = 0 (a profile's default): a model with a loop estimates and
    feeds forward as one without, since a loop the finger lacks is positive feedback."""
    path = [20.0] * 20 + list(np.linspace(20.0, 50.0, 60)) + list(np.linspace(50.0, 35.0, 40))
    loop = {"hysteresis_torque_nm": TORQUE_NM, "hysteresis_travel_deg": TRAVEL_DEG}
    left_out, plain = run(index_finger, path, loop_in_force=0, **loop), run(index_finger, path)
    np.testing.assert_array_equal(left_out["force"], plain["force"])
    np.testing.assert_array_equal(left_out["feedforward"], plain["feedforward"])
