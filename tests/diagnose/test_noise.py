"""The noise model: AR order and coefficients from a known process, nuisance offset and drift."""

from __future__ import annotations

import numpy as np
from scipy import signal

from hand_service.diagnose.residual import noise


def test_an_ar1_process_is_recovered_and_whitened() -> None:
    rng = np.random.default_rng(0)
    a = np.exp(-1.0 / (0.1 * 100.0))  # 0.1 s correlation at 100 Hz
    x = signal.lfilter([1.0], [1.0, -a], rng.normal(0.0, 1.0, 20_000))
    valid = np.ones(x.size, dtype=bool)
    model = noise.estimate(x, valid, 100.0, with_drift=False)
    assert model.order >= 1 and abs(model.ar[0] - a) < 0.03
    e = model.whiten(x, valid)[model.order:]
    rho1 = float(np.corrcoef(e[:-1], e[1:])[0, 1])
    assert abs(rho1) < 0.03 and abs(e.std() - 1.0) < 0.03


def test_white_noise_needs_no_filter() -> None:
    x = np.random.default_rng(1).normal(0.0, 0.3, 5000)
    assert noise.estimate(x, np.ones(x.size, dtype=bool), 100.0).order == 0


def test_offset_and_slow_drift_are_nuisance_a_fast_signal_is_not() -> None:
    n, rate = 3000, 100.0
    t = np.arange(n) / rate
    model = noise.nuisance_only(n, rate)
    slow = 0.8 + 0.5 * np.sin(2 * np.pi * t / 120.0 + 0.3)  # offset and a drift over minutes
    fast = np.sin(2 * np.pi * 1.0 * t)  # a 1 Hz response is physics
    assert np.abs(model.detrend(slow)).max() < 0.1 * 0.5 + 0.01  # within a tenth of the drift
    assert np.abs(model.detrend(fast) - fast).max() < 0.05


def test_the_start_motion_is_projected_out_with_the_drift_as_by_one_orthonormal_basis() -> None:
    """noise.StartMotion: the drift and the finger's free motion from the start projected
    out together, without orthonormalising the short start columns into dense ones."""
    from hand_service.config.profile import load_profile
    from hand_service.simulator import sim_finger

    n, rate = 20_000, 1000.0
    finger = sim_finger(load_profile(None).finger("index").model)
    start = noise.start_motion(finger, n, rate)
    model = noise.nuisance_only(n, rate, start)
    assert model.start is not None and model.start.columns.shape[0] < n // 4  # it dies out
    dense, _ = np.linalg.qr(np.column_stack((noise.drift_basis(n, rate), start)))
    rng = np.random.default_rng(3)
    swing = 5.0 * start[:, 1] + np.linspace(0.0, 2.0, n) + rng.normal(0.0, 0.1, n)
    for r in (rng.normal(0.0, 1.0, n), swing):
        expected = r - dense @ (dense.T @ r)
        assert np.abs(model.detrend(r) - expected).max() < 1e-9 * np.abs(r).max()
