"""The residual tests and the data split that diagnose's verdicts rest on."""

from __future__ import annotations

import numpy as np
import pytest

from hand_service.diagnose.model.problem import split_blocks, substeps_for
from hand_service.diagnose.residual import stats


def test_ljung_box_passes_white_noise_and_fails_a_ringing_residual() -> None:
    rng = np.random.default_rng(1)
    white = rng.normal(0.0, 0.5, 3000)
    p_values = np.array([stats.ljung_box(rng.normal(0.0, 0.5, 1000), 25).p_value for _ in range(400)])
    assert 0.02 < np.mean(p_values < 0.05) < 0.09  # about 5 % at the 5 % level
    t = np.arange(3000) / 100.0
    ringing = white + 1.0 * np.sin(2 * np.pi * 9.5 * t) * np.exp(-((t % 3.0) / 0.5))
    assert stats.ljung_box(white, 25).white
    assert stats.ljung_box(ringing, 25).p_value < 1e-6


def test_heldout_z_stays_low_for_a_change_that_only_fits_noise() -> None:
    rng = np.random.default_rng(2)
    truth = np.sin(np.linspace(0, 20, 1000))
    before = truth.copy()
    zs = []
    for _ in range(400):
        measured = truth + rng.normal(0.0, 0.5, truth.size)
        after = before + rng.normal(0.0, 0.05, truth.size)  # a change unrelated to the data
        zs.append(stats.heldout_z(measured, before, after, 0.5))
    # a change that only fits noise costs on held-out data: z is N(-‖δ‖/2σ, 1), never large
    expected = -np.sqrt(1000 * 0.05**2) / (2 * 0.5)
    assert np.mean(zs) == pytest.approx(expected, abs=0.2) and 0.8 < np.std(zs) < 1.2
    assert max(zs) < 3.0
    measured = truth + 0.3 * np.cos(np.linspace(0, 20, 1000)) + rng.normal(0.0, 0.5, truth.size)
    fixed = truth + 0.3 * np.cos(np.linspace(0, 20, 1000))
    assert stats.heldout_z(measured, before, fixed, 0.5) > 5.0


def test_cross_correlation_sees_a_delayed_input_in_the_residual() -> None:
    rng = np.random.default_rng(3)
    u = np.repeat(rng.uniform(0, 100, 60), 50)
    residual = rng.normal(0, 0.5, u.size)
    quiet = stats.cross_correlation(residual, u, 25, 100.0)
    leaky = stats.cross_correlation(residual + 0.004 * np.roll(u - u.mean(), 7), u, 25, 100.0)
    assert not quiet.outside
    assert leaky.outside and leaky.worst[0] == pytest.approx(0.07, abs=0.06)


def test_windows_mark_where_the_residual_stands_out() -> None:
    rng = np.random.default_rng(4)
    t = np.arange(3000) / 100.0
    residual = rng.normal(0, 0.5, t.size)
    burst = (t > 12.0) & (t < 13.0)
    residual[burst] += 1.0 * np.sin(2 * np.pi * 9.0 * t[burst])
    found = stats.windows(residual, np.ones(t.size, dtype=bool), t, 0.5, 100.0)
    assert found
    assert found[0][0] == pytest.approx(12.0, abs=0.4) and found[0][1] == pytest.approx(13.0, abs=0.4)
    assert stats.windows(rng.normal(0, 0.5, t.size), np.ones(t.size, dtype=bool), t, 0.5, 100.0) == []


def test_delta_bic_penalises_each_extra_parameter() -> None:
    assert stats.delta_bic(100.0, 100.0, 1000) == pytest.approx(-np.log(1000))
    assert stats.delta_bic(110.0, 100.0, 1000) > 80.0


@pytest.mark.parametrize("rate_hz", [100.0, 250.0, 500.0, 1000.0])
def test_blocks_interleave_and_substeps_keep_1_ms(rate_hz: float) -> None:
    n = int(30 * rate_hz)
    fit, held, blocks = split_blocks(n, rate_hz, start=int(0.5 * rate_hz))
    assert not np.any(fit & held)
    assert np.all((fit | held)[int(0.5 * rate_hz):])
    assert 0.2 < held.sum() / (fit.sum() + held.sum()) < 0.3
    held_starts = [a for a, _ in blocks if held[a]]
    assert held_starts[0] < n / 4 and held_starts[-1] > 3 * n / 4  # spread over the recording
    assert substeps_for(rate_hz) == 1  # the simulator chooses its own steps from the dynamics
