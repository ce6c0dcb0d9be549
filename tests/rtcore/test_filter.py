"""The C Butterworth against scipy.signal: transfer function and output from rest."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from rtcore import MODE_VENT, ConfigError, FingerConfig, Hand, HandConfig, butter_design

CASES = [(order, fc, fs) for order in (2, 4) for fc, fs in
         ((2.0, 100.0), (8.0, 100.0), (15.0, 100.0), (25.0, 100.0), (40.0, 100.0), (30.0, 500.0),
          (100.0, 1000.0))]


@pytest.mark.parametrize(("order", "cutoff_hz", "sample_rate_hz"), CASES)
def test_transfer_function_matches_scipy(order: int, cutoff_hz: float, sample_rate_hz: float) -> None:
    ours = butter_design(order, cutoff_hz, sample_rate_hz)
    theirs = signal.butter(order, cutoff_hz, fs=sample_rate_hz, output="sos")
    freqs = np.linspace(0.0, 0.49 * sample_rate_hz, 100)
    _, h_ours = signal.sosfreqz(ours, worN=freqs, fs=sample_rate_hz)
    _, h_theirs = signal.sosfreqz(theirs, worN=freqs, fs=sample_rate_hz)
    relative = np.abs(h_ours - h_theirs) / np.abs(h_theirs)
    assert relative.max() <= 1e-9, f"worst relative error {relative.max():.3g}"


@pytest.mark.parametrize(("order", "cutoff_hz", "sample_rate_hz"), CASES)
def test_output_from_rest_matches_sosfilt(index_finger: FingerConfig, order: int, cutoff_hz: float,
                                          sample_rate_hz: float) -> None:
    """Run the real control step (identity calibration, vent mode) on a noisy chirp."""
    finger = index_finger.replace(filter_order=order, filter_cutoff_hz=cutoff_hz,
                                  sensor_gain_deg_per_mv=1.0, sensor_offset_deg=0.0)
    hand = Hand(HandConfig([finger], sample_rate_hz=sample_rate_hz))
    hand.inputs.mode[:] = MODE_VENT
    n = 2000
    t = np.arange(n) / sample_rate_hz
    rng = np.random.default_rng(order * 1000 + int(cutoff_hz))
    x = 60.0 * signal.chirp(t, 0.1, t[-1], 0.45 * sample_rate_hz) + rng.normal(0, 2.0, n)
    x[0] = 0.0  # from rest
    y = np.empty(n)
    for k in range(n):
        hand.inputs.sensor_mv[0] = x[k]
        hand.step()
        y[k] = hand.outputs.angle_filt_deg[0]
    expected = signal.sosfilt(signal.butter(order, cutoff_hz, fs=sample_rate_hz, output="sos"), x)
    worst = np.max(np.abs(y - expected)) / np.max(np.abs(x))
    assert worst <= 1e-9, f"worst error {worst:.3g} of the peak"


@pytest.mark.parametrize(("order", "cutoff_hz", "sample_rate_hz"),
                         [(3, 10.0, 100.0), (2, 50.0, 100.0), (2, 0.0, 100.0), (2, 10.0, 0.0)])
def test_bad_designs_are_refused(order: int, cutoff_hz: float, sample_rate_hz: float) -> None:
    with pytest.raises(ConfigError):
        butter_design(order, cutoff_hz, sample_rate_hz)
