"""The force estimate's tare: the N that zeroes a free hold's estimate restores the
finger's own N/k, whatever k's error."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hand_service.config.profile import load_profile
from hand_service.identification.tare import MIN_EFFECTIVE_KPA, apply_tare, tare_gain


def _free_hold(k_error: float, n_error: float) -> tuple:
    truth = load_profile(None)
    true = truth.finger("index").model
    angle_rad = math.radians(80.0)
    chamber_kpa = true.stiffness_nm_per_rad * angle_rad / true.pressure_gain_nm_per_kpa  # N p = k θ, free
    mine = true.with_changes(stiffness_nm_per_rad=true.stiffness_nm_per_rad * (1.0 + k_error),
                             pressure_gain_nm_per_kpa=true.pressure_gain_nm_per_kpa * (1.0 + n_error))
    lever_m = mine.prbm("test").lever_arm_m
    torque_nm = mine.pressure_gain_nm_per_kpa * chamber_kpa - mine.stiffness_nm_per_rad * angle_rad
    estimate_n = torque_nm / lever_m
    return truth, true, mine, np.full(50, estimate_n), np.full(50, chamber_kpa)


@pytest.mark.parametrize("k_error, n_error", [(0.05, -0.05), (-0.05, 0.05), (0.05, 0.05), (0.0, 0.0)])
def test_the_tare_restores_the_fingers_ratio(k_error: float, n_error: float) -> None:
    _, true, mine, estimate, chamber = _free_hold(k_error, n_error)
    tare = tare_gain(mine, "index", estimate, chamber)
    ratio = tare.gain_after_nm_per_kpa / mine.stiffness_nm_per_rad
    assert ratio == pytest.approx(true.pressure_gain_nm_per_kpa / true.stiffness_nm_per_rad, rel=1e-9)
    assert tare.gain_change_pct == pytest.approx(100.0 * ((1.0 + k_error) / (1.0 + n_error) - 1.0), rel=1e-6)


def test_the_tare_writes_only_its_fingers_gain() -> None:
    truth, _, mine, estimate, chamber = _free_hold(0.05, -0.05)
    tare = tare_gain(mine, "index", estimate, chamber)
    tared = apply_tare(truth, tare)
    assert tared.finger("index").model.pressure_gain_nm_per_kpa == tare.gain_after_nm_per_kpa
    assert tared.finger("thumb").model == truth.finger("thumb").model


def test_the_tare_refuses_a_hold_it_cannot_read() -> None:
    _, _, mine, estimate, chamber = _free_hold(0.05, -0.05)
    with pytest.raises(ValueError, match="effective pressure"):
        tare_gain(mine, "index", estimate, np.full(50, 0.5 * MIN_EFFECTIVE_KPA))
    with pytest.raises(ValueError, match="one chamber pressure per estimate"):
        tare_gain(mine, "index", estimate, chamber[:-1])
    with pytest.raises(ValueError, match="non-finite"):
        tare_gain(mine, "index", np.full(50, np.nan), chamber)
