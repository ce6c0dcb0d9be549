"""One finger's dynamics alone (csrc/rtcore_sim_plant.h, rtcore.motion): the same
integration the simulated hand runs, an external torque as part of the drive, and the
exact linear finger against scipy's discretisation."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from rtcore import ConfigError, Effects
from rtcore.motion import FingerMotions
from rtcore.sim import SimFinger, simulate
from tests.rtcore.test_sim_integrator import EFFECTS, OVERDAMPED, PAPER, held_levels, zoh_reference

RATE_HZ = 100.0


def drive(motions: FingerMotions, commands: np.ndarray, torque_nm: float = 0.0) -> np.ndarray:
    """The first finger's angle (deg) at each sample, commands[k] held over sample k."""
    angle = [math.degrees(motions.angle_rad[0])]
    for p in commands[:-1]:
        motions.advance(np.full(motions.n_fingers, p), np.full(motions.n_fingers, torque_nm), 1.0 / RATE_HZ)
        angle.append(math.degrees(motions.angle_rad[0]))
    return np.array(angle)


@pytest.mark.parametrize("effect", ["all_but_dead_time", "valve_lag", "coulomb_friction", "cubic_stiffness"])
def test_the_hand_and_the_finger_alone_step_the_same_dynamics(effect: str) -> None:
    effects = dataclasses.replace(EFFECTS["all"], dead_time_s=0.0) if effect == "all_but_dead_time" \
        else EFFECTS[effect]
    finger = SimFinger(dataclasses.replace(PAPER, effects=effects), contact_angle_deg=40.0,
                       contact_stiffness_n_per_m=2000.0, contact_damping_ns_per_m=5.0)
    commands = held_levels(RATE_HZ, 2.0)
    hand_deg, _ = simulate(finger, commands, RATE_HZ, substeps=1)
    alone_deg = drive(FingerMotions([finger]), commands)
    np.testing.assert_array_equal(alone_deg, hand_deg)


@pytest.mark.parametrize("plant", [PAPER, OVERDAMPED])
def test_a_linear_finger_is_exact(plant: object) -> None:
    commands = held_levels(RATE_HZ, 2.0, seed=3)
    motions = FingerMotions([SimFinger(plant)])
    motions.start(0, angle_deg=5.0, velocity_deg_per_s=-20.0)
    reference = zoh_reference(plant, commands, RATE_HZ, 5.0, -20.0)
    np.testing.assert_allclose(drive(motions, commands), reference, rtol=0.0, atol=1e-9)


def test_an_external_torque_drives_as_a_pressure_does() -> None:
    torque_nm = -0.2  # a contact pushing the finger back
    finger = SimFinger(PAPER)
    commands = held_levels(RATE_HZ, 2.0, seed=5)
    pushed = drive(FingerMotions([finger]), commands, torque_nm)
    equivalent = drive(FingerMotions([finger]), commands + torque_nm / PAPER.pressure_gain_nm_per_kpa)
    np.testing.assert_allclose(pushed, equivalent, rtol=0.0, atol=1e-9)
    assert np.ptp(pushed - drive(FingerMotions([finger]), commands)) > 1.0  # the torque moved it


def test_fingers_advance_independently() -> None:
    fingers = [SimFinger(PAPER), SimFinger(OVERDAMPED)]
    together = FingerMotions(fingers)
    together.advance(np.array([80.0, 40.0]), np.array([0.0, 0.05]), 0.3)
    for i, finger in enumerate(fingers):
        alone = FingerMotions([finger])
        alone.advance(np.array([[80.0, 40.0][i]]), np.array([[0.0, 0.05][i]]), 0.3)
        assert together.angle_rad[i] == alone.angle_rad[0]
        assert together.velocity_rad_per_s[i] == alone.velocity_rad_per_s[0]


@pytest.mark.parametrize(("input_kpa", "torque_nm", "duration_s"),
                         [(math.nan, 0.0, 0.01), (50.0, math.inf, 0.01), (50.0, 0.0, 0.0),
                          (50.0, 0.0, -1.0), (50.0, 0.0, math.nan)])
def test_a_non_finite_drive_or_no_time_changes_nothing(input_kpa: float, torque_nm: float,
                                                       duration_s: float) -> None:
    motions = FingerMotions([SimFinger(PAPER)])
    motions.start(0, angle_deg=10.0, velocity_deg_per_s=3.0, chamber_kpa=20.0)
    before = (motions.angle_rad.copy(), motions.velocity_rad_per_s.copy(), motions.chamber_kpa.copy())
    motions.advance(np.array([input_kpa]), np.array([torque_nm]), duration_s)
    after = (motions.angle_rad, motions.velocity_rad_per_s, motions.chamber_kpa)
    for old, new in zip(before, after, strict=True):
        np.testing.assert_array_equal(old, new)


def test_a_finger_the_dynamics_cannot_run_is_refused() -> None:
    with pytest.raises(ConfigError, match="finger 1"):
        FingerMotions([SimFinger(PAPER), SimFinger(dataclasses.replace(PAPER, inertia_kgm2=0.0))])
    with pytest.raises(ConfigError):
        FingerMotions([SimFinger(dataclasses.replace(PAPER, effects=Effects(coulomb_torque_nm=-1.0)))])
    motions = FingerMotions([SimFinger(PAPER)])
    with pytest.raises(ConfigError):
        motions.start(0, angle_deg=math.nan)


def test_a_moved_contact_stops_the_finger_where_it_now_stands() -> None:
    finger = SimFinger(PAPER, contact_angle_deg=40.0, contact_stiffness_n_per_m=20000.0,
                       contact_damping_ns_per_m=5.0)
    motions = FingerMotions([finger])
    for wall_deg in (40.0, 20.0):
        motions.move_contact(0, wall_deg)
        for _ in range(300):  # 3 s at 100 kPa: free, the finger would bend to 119 deg
            motions.advance(np.array([100.0]), np.array([0.0]), 0.01)
        assert wall_deg < math.degrees(motions.angle_rad[0]) < wall_deg + 2.0
