"""Skipped samples, as a daemon on a loaded PC leaves them (docs/formats.md allows up to
10 %): the residual there is interpolated between the measured samples beside it, not the
angle (Problem.residual). An outside probe found a clean recording with 5 % of its rows
skipped at random called `unexplained` (Ljung-Box p = 1e-18, the input test p = 3e-55):
the angle interpolated across a ringing finger's skipped sample missed the simulated curve
by degrees, and the fitted offset and the noise filter carried that."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hand_service.config.model import FingerModel
from hand_service.diagnose.model.problem import build_problem
from tests.diagnose.truth import cases as cs
from tests.diagnose.truth.battery import diagnose_in_process
from tests.diagnose.truth.files import read_rows, write_rows


def skip_rows(recording: Path, fraction: float, seed: int) -> Path:
    """The recording with `fraction` of its rows left out at random, only where the command
    did not change (a skipped tick holds the last command: that is what the file says)."""
    head, rows = read_rows(recording)
    command = np.array([float(row[1]) for row in rows])
    held = np.flatnonzero(np.r_[False, command[1:] == command[:-1]])[:-1]  # never the last row
    rng = np.random.default_rng(seed)
    drop = set(rng.choice(held, size=int(fraction * len(rows)), replace=False).tolist())
    kept = [row for i, row in enumerate(rows) if i not in drop]
    return write_rows(recording.with_name(f"{recording.stem}-skipped.csv"), head, kept)


def test_a_clean_recording_with_5_percent_of_its_rows_skipped_stays_clean(tmp_path: Path) -> None:
    spec = cs.CaseSpec(cs.CLEAN, "steps", 0, "none", "ringing", 100.0)
    rec, model = cs.write(cs.build(spec), tmp_path)
    result = diagnose_in_process(skip_rows(rec, 0.05, seed=1), model, tmp_path)
    assert result["verdict"] in ("consistent", "parameters_only"), result["warnings"]
    assert result["effects"] == []
    assert result["whiteness"]["refit"]["p_value"] > 1e-3


def paper_finger() -> FingerModel:
    return FingerModel(inertia_kgm2=1.6e-4, stiffness_nm_per_rad=0.57, damping_nms_per_rad=3e-3,
                       pressure_gain_nm_per_kpa=0.012)


def test_the_residual_is_interpolated_at_a_skipped_sample_not_the_angle() -> None:
    """A finger whose angle curves between two samples: the residual at the skipped one is
    the mean of its neighbours' residuals, whatever the interpolated angle there says."""
    model = paper_finger()
    n = 300
    t = np.arange(n) / 100.0
    angle = 30.0 * np.sin(2 * np.pi * 3.0 * t)  # 3 Hz: far from linear over 20 ms
    missing = np.zeros(n, dtype=bool)
    missing[[100, 151, 152]] = True
    measured = angle.copy()
    idx = np.arange(n)
    measured[missing] = np.interp(idx[missing], idx[~missing], angle[~missing])  # as regular_grid does
    problem = build_problem(model, t, np.zeros(n), measured, 100.0, missing)
    simulated = angle + 0.01 * idx  # a residual that is a slow ramp where measured
    r = problem.residual(simulated)
    np.testing.assert_allclose(r, -0.01 * idx, atol=1e-12)
    assert not problem.fit_mask[missing].any() and not problem.held_mask[missing].any()


def test_skipped_samples_inside_a_run_join_the_noise_estimate() -> None:
    """The skipped samples whose last measured sample is in the mask join it (the noise's
    lags evenly spaced); those inside a held-out block do not."""
    model = paper_finger()
    n = 12
    missing = np.zeros(n, dtype=bool)
    missing[[2, 3, 7]] = True
    problem = build_problem(model, np.arange(n) / 100.0, np.zeros(n), np.zeros(n), 100.0, missing)
    mask = np.ones(n, dtype=bool)
    mask[6:9] = False  # a held-out block
    mask &= ~missing
    np.testing.assert_array_equal(np.flatnonzero(problem.with_skipped(mask)), [0, 1, 2, 3, 4, 5, 9, 10, 11])
