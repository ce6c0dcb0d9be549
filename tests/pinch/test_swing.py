"""The fingers' sideways bend under the object's torque: at rest it carries gravity's
torque; loaded at once it overshoots towards twice that; loaded over the hand's release
it barely overshoots."""

from __future__ import annotations

import numpy as np
import pytest

from hand_service.pinch.objects import SCREWDRIVER
from hand_service.pinch.plant import RELEASE_S
from hand_service.pinch.swing import SIDE_DAMPING_RATIO, Swing, side_stiffness_nm_per_rad

DT_S = 1e-3


def peak_over_static(ramp_s: float) -> tuple[float, float]:
    stiffness = side_stiffness_nm_per_rad(np.array([[0.075, 0.095]]))
    swing = Swing(stiffness, np.array([SCREWDRIVER.inertia_kgm2]), DT_S)
    torque_nm = SCREWDRIVER.mass_kg * 9.81 * SCREWDRIVER.com_lever_m
    peak = 0.0
    for i in range(3000):
        share = min(i * DT_S / ramp_s, 1.0) if ramp_s > 0.0 else 1.0
        swing.advance(np.array([share * torque_nm]))
        peak = max(peak, float(swing.torque_nm[0]))
    return peak / torque_nm, float(swing.torque_nm[0]) / torque_nm


def test_the_bend_carries_gravitys_torque_and_overshoots_when_loaded_at_once() -> None:
    peak, settled = peak_over_static(0.0)
    assert settled == pytest.approx(1.0, abs=1e-3)
    # a damped oscillator's first overshoot: exp(-zeta pi / sqrt(1 - zeta^2))
    overshoot = np.exp(-SIDE_DAMPING_RATIO * np.pi / np.sqrt(1.0 - SIDE_DAMPING_RATIO**2))
    assert peak == pytest.approx(1.0 + overshoot, abs=0.02)
    gentle, _ = peak_over_static(RELEASE_S)
    assert 1.0 < gentle < 1.0 + overshoot / 3.0


def test_a_fast_swing_stays_stable_at_the_substep() -> None:
    """The coin's and the chip's swings are hundreds of rad/s: the exact step keeps them bounded."""
    swing = Swing(np.array([0.1]), np.array([1e-7]), DT_S)
    for _ in range(1000):
        swing.advance(np.array([1e-3]))
    assert abs(swing.angle_rad[0] - 1e-2) < 2e-2
