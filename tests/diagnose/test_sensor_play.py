"""The play operator that outside_library/sensor_play.py puts between the simulated angle and
the sensor: its prefix scan of clamps against the operator's definition, sample by sample."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from hand_service.diagnose.outside_library.sensor_play import play


def _one_by_one(angle_deg: np.ndarray, half_width_deg: float) -> np.ndarray:
    """y[i] = min(max(y[i−1], x[i] − h), x[i] + h), from y = x[0]."""
    out = np.empty_like(angle_deg)
    reading = angle_deg[0] if angle_deg.size else 0.0
    for i, x in enumerate(angle_deg):
        reading = min(max(reading, x - half_width_deg), x + half_width_deg)
        out[i] = reading
    return out


@settings(max_examples=200, deadline=None)
@given(arrays(np.float64, st.integers(0, 300), elements=st.floats(-90.0, 90.0)),
       st.floats(0.0, 20.0))
def test_the_scan_is_the_operator(angle_deg: np.ndarray, half_width_deg: float) -> None:
    assert np.array_equal(play(angle_deg, half_width_deg), _one_by_one(angle_deg, half_width_deg))


def test_a_swing_within_the_play_is_not_read_and_a_ramp_is_read_shifted() -> None:
    """A ring of ±1° inside a play of ±1.5° leaves the reading still; a ramp up is read
    1.5° behind, and turning back the reading holds for 3° of the finger's travel."""
    t = np.linspace(0.0, 2.0, 401)
    assert np.array_equal(play(np.sin(2 * np.pi * 3 * t), 1.5), np.zeros(t.size))
    up_and_back = np.concatenate((np.linspace(0.0, 10.0, 101), np.linspace(10.0, 0.0, 101)[1:]))
    read = play(up_and_back, 1.5)
    assert np.allclose(read[20:101], up_and_back[20:101] - 1.5)
    held = read[101:] == read[100]
    assert np.allclose(up_and_back[101:][held].min(), 10.0 - 3.0, atol=0.11) and read[100] == 8.5
