"""The simulator's loop in the angle (csrc/rtcore_sim.h, hysteresis_*: Dahl's form, the
rival diagnose fits in dry friction's place,
hand_service/diagnose/outside_library/material_hysteresis.py) against an integration
written apart from it: the three states (θ, θ', z) by LSODA, with the loop's
ODE z' = (θ' − |θ'|·z)/d as Dahl wrote it, not the solved form per step the simulator uses;
on the three plant families, a triangle (slow turns) and steps (turns in the ringing)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from rtcore import Prbm
from rtcore.config import ConfigError
from rtcore.sim import SimFinger, simulate_angle

RATE_HZ = 100.0
FAMILIES = {  # (the plant, the longest step LSODA may take)
    "ringing": (Prbm(inertia_kgm2=1.6e-4, damping_nms_per_rad=0.003, stiffness_nm_per_rad=0.57,
                     pressure_gain_nm_per_kpa=0.0119, lever_arm_m=0.0), 1e-4),
    "overdamped": (Prbm(inertia_kgm2=1e-5, damping_nms_per_rad=0.05, stiffness_nm_per_rad=0.5,
                        pressure_gain_nm_per_kpa=0.01, lever_arm_m=0.0), 1e-4),
    "stiff": (Prbm(inertia_kgm2=0.002, damping_nms_per_rad=0.05, stiffness_nm_per_rad=5.0,
                   pressure_gain_nm_per_kpa=0.1, lever_arm_m=0.0), 1e-4),
}
TRAVEL_DEG = 3.0
TORQUE_SHARE = 0.15  # the loop's torque, of k·1 rad


def dahl_lsoda(prbm: Prbm, torque_nm: float, travel_deg: float, command_kpa: np.ndarray,
               max_step_s: float) -> np.ndarray:
    """The angle (deg) at every sample, each command held over its period."""
    a, b, k, n = (prbm.inertia_kgm2, prbm.damping_nms_per_rad, prbm.stiffness_nm_per_rad,
                  prbm.pressure_gain_nm_per_kpa)
    d = np.radians(travel_deg)
    state, out = np.zeros(3), [0.0]
    for p in command_kpa[:-1]:
        def rhs(_t: float, x: np.ndarray, p: float = p) -> list[float]:
            return [x[1], (n * p - b * x[1] - k * x[0] - torque_nm * x[2]) / a, (x[1] - abs(x[1]) * x[2]) / d]
        state = solve_ivp(rhs, (0.0, 1.0 / RATE_HZ), state, method="LSODA", rtol=1e-10, atol=1e-12,
                          max_step=max_step_s).y[:, -1]
        out.append(float(np.degrees(state[0])))
    return np.array(out)


def commands(prbm: Prbm) -> dict[str, np.ndarray]:
    t = np.arange(0.0, 3.0, 1.0 / RATE_HZ)
    full_kpa = np.radians(60.0) * prbm.stiffness_nm_per_rad / prbm.pressure_gain_nm_per_kpa
    return {"triangle": full_kpa * (1.0 - np.abs(t % 2.0 - 1.0)),
            "steps": full_kpa * (np.floor(t * 1.5) % 3) / 2}


@pytest.mark.parametrize("family", FAMILIES)
def test_the_loop_agrees_with_dahls_ode_integrated_apart(family: str) -> None:
    prbm, max_step_s = FAMILIES[family]
    torque_nm = TORQUE_SHARE * prbm.stiffness_nm_per_rad
    finger = SimFinger(prbm, supply_max_kpa=1e4, hysteresis_torque_nm=torque_nm,
                       hysteresis_travel_deg=TRAVEL_DEG)
    for name, command in commands(prbm).items():
        truth = dahl_lsoda(prbm, torque_nm, TRAVEL_DEG, command, max_step_s)
        without = dataclasses.replace(finger, hysteresis_torque_nm=0.0)
        plain = simulate_angle(without, command, RATE_HZ, substeps=0)
        assert np.max(np.abs(plain - truth)) > 0.02 * np.ptp(truth), name  # the loop matters here
        for substeps in (0, 10):  # the dynamics' own steps (spans too), and a tenth of a period at most
            angle = simulate_angle(finger, command, RATE_HZ, substeps=substeps)
            assert np.max(np.abs(angle - truth)) < 1e-3 * np.ptp(truth), (name, substeps)


def test_no_loop_is_the_plain_finger_bit_for_bit() -> None:
    prbm, _ = FAMILIES["ringing"]
    command = commands(prbm)["steps"]
    plain = simulate_angle(SimFinger(prbm, supply_max_kpa=1e4), command, RATE_HZ, substeps=0)
    unused = simulate_angle(SimFinger(prbm, supply_max_kpa=1e4, hysteresis_travel_deg=5.0), command, RATE_HZ,
                            substeps=0)
    assert np.array_equal(plain, unused)


@pytest.mark.parametrize("torque_nm, travel_deg", [(0.1, 0.0), (0.1, -1.0), (0.1, float("nan")),
                                                    (-0.1, 3.0), (float("inf"), 3.0)])
def test_a_loop_without_a_travel_or_with_a_bad_torque_is_refused(torque_nm: float, travel_deg: float) -> None:
    prbm, _ = FAMILIES["ringing"]
    finger = SimFinger(prbm, hysteresis_torque_nm=torque_nm, hysteresis_travel_deg=travel_deg)
    with pytest.raises(ConfigError):
        simulate_angle(finger, np.zeros(10), RATE_HZ)
