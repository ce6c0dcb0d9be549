"""The Sobol study's wiring (the study itself is a bench run, docs/replicate.md): the
constants it varies are set for a run and put back, the mismatch scales, and SALib's
indices rank a known function's inputs."""

from __future__ import annotations

import numpy as np
import pytest
from SALib.sample import sobol as sobol_sample

from hand_service.pinch import plant, trials
from hand_service.pinch.mismatch import NONE, PAPER_MISMATCH
from hand_service.pinch.sobol import PARAMETERS, analyse, main, physics, problem, scaled


def test_physics_sets_the_constants_and_puts_them_back() -> None:
    before = (plant.PAD_STIFFNESS_N_PER_M, plant.FINGER_SHEAR_MODULUS_PA, trials.DESIGN_WIDTH_M,
              trials.CLOSING_RATE_KPA_PER_S)
    with physics(3000.0, 2.0, 0.02, 150.0):
        assert plant.PAD_STIFFNESS_N_PER_M == 3000.0 and trials.DESIGN_WIDTH_M == 0.02
        assert 2.0 * before[1] == plant.FINGER_SHEAR_MODULUS_PA
        assert trials.pair_gap_m(np.array([0.0, 0.0])) == 0.02
    assert before == (plant.PAD_STIFFNESS_N_PER_M, plant.FINGER_SHEAR_MODULUS_PA, trials.DESIGN_WIDTH_M,
            trials.CLOSING_RATE_KPA_PER_S)


def test_the_defaults_lie_in_the_ranges_and_the_mismatch_scales() -> None:
    defaults = {"pad_stiffness_n_per_m": plant.PAD_STIFFNESS_N_PER_M, "design_width_m": trials.DESIGN_WIDTH_M,
                "closing_rate_kpa_per_s": trials.CLOSING_RATE_KPA_PER_S, "friction_factor": 1.0,
                "torsion_factor": 1.0, "mismatch_factor": 1.0}
    for name, low, high in PARAMETERS:
        assert low <= defaults[name] <= high, name
    assert scaled(PAPER_MISMATCH, 0.0) == NONE
    assert scaled(PAPER_MISMATCH, 2.0).hysteresis_deg == 2.0 * PAPER_MISMATCH.hysteresis_deg
    assert scaled(PAPER_MISMATCH, 2.0).stiffening == 2.0 * PAPER_MISMATCH.stiffening


def test_sobol_indices_rank_a_known_function() -> None:
    x = sobol_sample.sample(problem(), 64, calc_second_order=False, seed=1)
    unit = (x - x.min(axis=0)) / np.ptp(x, axis=0)
    y = np.column_stack([4.0 * unit[:, 0] + unit[:, 4], unit[:, 1] * unit[:, 5]])
    y[3, 0] = np.nan  # a run without a tuning window
    first, second = analyse(y, seed=1)
    assert int(np.argmax(first["S1"])) == 0 and first["S1"][0] > 0.8
    assert first["ST"][2] < 0.05  # not in the function
    assert set(np.argsort(second["ST"])[-2:]) == {1, 5}


@pytest.mark.slow
def test_the_sobol_study_runs_end_to_end(capsys: pytest.CaptureFixture[str]) -> None:
    """The smallest study (N = 2, 16 runs of 2 trials a cell): every object and parameter
    gets its indices, with the sample size stated."""
    assert main(["--base-samples", "2", "--trials", "2"]) == 0
    out = capsys.readouterr().out
    assert "16 runs (N = 2, D = 6), 2 trials a cell, seed 1" in out
    rows = [line for line in out.splitlines() if line.startswith("| ") and "points |" in line]
    assert len(rows) == 3 * len(PARAMETERS)
