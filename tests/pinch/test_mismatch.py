"""The mismatched plant: stiffening, the moving contact point and the flex sensor's bow act
on the plant and not on the controller's PRBM; the lab's calibration run again on it; the
force estimate's error against the plant's true force grows with the mismatch."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from hand_service.config.profile import Profile
from hand_service.pinch.mismatch import (
    NONE,
    PAPER_MISMATCH,
    BoardValves,
    Hysteresis,
    Mismatch,
    ValveLag,
    identify_on_plant,
)
from hand_service.pinch.objects import COIN, SCREWDRIVER, Placements
from hand_service.pinch.trials import Cell, run_cells


def test_the_mismatch_terms() -> None:
    m = Mismatch(stiffening=0.1, reference_kpa=100.0, lever_drift_per_rad=0.2, sensor_bow_deg=2.0)
    # k (1 + c p / p_ref) θ - k θ at 50 kPa, 0.5 rad
    assert m.stiffening_torque_nm(np.array([0.6]), np.array([0.5]), np.array([50.0]))[0] == pytest.approx(
        0.6 * 0.1 * 0.5 * 0.5)
    assert m.contact_lever_m(np.array([0.04]), np.array([0.5]))[0] == pytest.approx(0.04 * 1.1)
    assert m.sensed_deg(np.array([0.0, 75.0, 150.0])) == pytest.approx([0.0, 77.0, 150.0])
    assert NONE.sensed_deg(np.array([33.0]))[0] == 33.0
    assert NONE.stiffening_torque_nm(np.array([0.6]), np.array([0.5]), np.array([50.0]))[0] == 0.0


def test_the_boards_valves_fill_faster_than_they_vent_behind_their_dead_time() -> None:
    valves = BoardValves(fill_tau_s=(("index", 0.04),), vent_over_fill=4.0, dead_time_s=0.003)
    lag = ValveLag(valves, np.array([valves.fill_tau_of("index")]), 1e-3)
    got = [lag.step(np.array([100.0]))[0] for _ in range(43)]
    assert got[2] == 0.0 and got[3] > 0.0  # 3 ms of dead time
    assert got[42] == pytest.approx(100.0 * (1.0 - np.exp(-0.040 / 0.04)), rel=1e-9)  # one fill lag
    got = [lag.step(np.array([0.0]))[0] for _ in range(163)]
    assert got[162] == pytest.approx(got[2] * np.exp(-0.160 / 0.16), rel=1e-9)  # one vent lag


def test_the_hysteresis_is_a_loop_of_twice_its_width_whatever_the_speed() -> None:
    """The play operator's torque against a slow and a fast sweep of the angle: +k h on the
    way up, -k h on the way down, the same at both speeds."""
    for samples in (50, 5000):
        h = Hysteresis(np.radians(1.0), (1,))
        k = np.array([0.6])
        up = np.linspace(0.0, 1.0, samples)
        rising = [h.torque_nm(k, np.array([a]))[0] for a in up]
        falling = [h.torque_nm(k, np.array([a]))[0] for a in up[::-1]]
        assert rising[-1] == pytest.approx(0.6 * np.radians(1.0))
        assert falling[-1] == pytest.approx(-0.6 * np.radians(1.0))


def test_the_lab_calibrates_again_on_the_mismatched_plant(truth: Profile, tmp_path: Path) -> None:
    """A stiffer finger under pressure bends less: `calibrate gain` finds a smaller N; the
    sensor's bow moves `calibrate sensor`'s map; without a mismatch both stay."""
    same = identify_on_plant(truth, truth, NONE, 1, tmp_path)
    stiff = identify_on_plant(truth, truth, Mismatch(stiffening=0.05), 1, tmp_path)
    bowed = identify_on_plant(truth, truth, Mismatch(sensor_bow_deg=3.0), 1, tmp_path)
    for t, s, k, b in zip(truth.fingers, same.fingers, stiff.fingers, bowed.fingers, strict=True):
        n_true = t.model.pressure_gain_nm_per_kpa
        assert s.model.pressure_gain_nm_per_kpa == pytest.approx(n_true, rel=0.01)
        assert k.model.pressure_gain_nm_per_kpa < 0.95 * n_true
        assert s.sensor_gain_deg_per_mv == pytest.approx(t.sensor_gain_deg_per_mv, rel=0.005)
        # the bow is symmetric over the span: the linear map takes off its mean over the
        # calibration angles (0 to 150 deg every 10) as an offset
        mean_bow_deg = 3.0 * np.mean(np.sin(np.pi * np.arange(16) / 15))
        assert b.sensor_offset_deg - t.sensor_offset_deg == pytest.approx(-mean_bow_deg, abs=0.3)


def test_the_estimate_error_grows_with_the_mismatch(truth: Profile, tmp_path: Path) -> None:
    """Against the exact plant, the estimate's error is the closing's transients and the
    noise; on the mismatched plant, with the lab's calibration run again on it, the gain
    fitted over the whole sweep is wrong at the pinch's pressure and the error grows."""
    pair = ("thumb", "index")
    cells = [Cell(pair, SCREWDRIVER, "force", np.array([2.7]), Placements.nominal(SCREWDRIVER, 1)),
             Cell(pair, COIN, "force", np.array([0.5]), Placements.nominal(COIN, 1))]
    exact = run_cells(truth, truth, cells, 3)
    calibrated = identify_on_plant(truth, truth, PAPER_MISMATCH, 1, tmp_path)
    mismatched = run_cells(truth, calibrated, cells, 3, mismatch=PAPER_MISMATCH)
    assert exact.contact_ticks.sum() > 500 and mismatched.contact_ticks.sum() > 500
    assert mismatched.estimate_rmse_n() > 1.5 * exact.estimate_rmse_n()
    # the plant's contact point moves: the true force held differs from the exact plant's
    drift = dataclasses.replace(NONE, lever_drift_per_rad=0.3)
    lever_only = run_cells(truth, truth, cells, 3, mismatch=drift)
    assert abs(lever_only.held_force_n[0] - exact.held_force_n[0]) > 0.1
