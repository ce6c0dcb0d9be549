"""The advice after `insufficient_excitation` is about this recording's command."""

from __future__ import annotations

import numpy as np
from scipy import signal

from hand_service.diagnose.recording.excitation import analyse

RATE_HZ = 100.0
K, A = 0.57, 1.6e-4  # resonance about 9.5 Hz
T = np.arange(int(30 * RATE_HZ)) / RATE_HZ


def test_a_single_slow_sine_is_named_as_such() -> None:
    e = analyse(40 + 30 * np.sin(2 * np.pi * 1.0 * T), RATE_HZ, K, A)
    assert e.tone_hz is not None and abs(e.tone_hz - 1.0) < 0.05
    assert "single sine at 1 Hz" in e.sentence() and "near 9.5 Hz" in e.sentence()


def test_a_slow_triangle_is_not_called_a_sine() -> None:
    """A ramp up and down (0 -> 95 -> 0 kPa, 10 s a cycle): 98.5 % of its power at one
    frequency, but no sine (an outside probe's ramp was called "a single sine")."""
    triangle = 47.5 * (1.0 + signal.sawtooth(2 * np.pi * T / 10.0, 0.5))
    e = analyse(triangle, RATE_HZ, K, A)
    assert e.tone_hz is not None and abs(e.tone_hz - 0.1) < 0.02
    assert "sine" not in e.sentence() and "ramp up and down" in e.sentence()


def test_a_chirp_through_the_resonance_is_not_called_a_sine() -> None:
    e = analyse(40 + 30 * signal.chirp(T, 0.1, T[-1], 20.0), RATE_HZ, K, A)
    assert e.tone_hz is None and e.near > 0.05 and e.slow > 0.05
    assert "sine" not in e.sentence()


def test_slow_steps_lack_the_resonance_band() -> None:
    steps = np.repeat(np.random.default_rng(0).uniform(0, 80, 20), int(1.5 * RATE_HZ))
    smooth = signal.lfilter([0.02], [1, -0.98], steps)  # a valve that only ramps slowly
    e = analyse(smooth, RATE_HZ, K, A)
    assert e.near < 0.05 and "content near 9.5 Hz" in e.advice() and "slow" not in e.advice()


def test_a_constant_command_barely_moves() -> None:
    assert "barely moves" in analyse(np.full(T.size, 30.0), RATE_HZ, K, A).sentence()


def test_two_pulses_are_not_said_to_repeat() -> None:
    """Two ramps up and down in 90 s at 25 Hz: nearly all their power sits at one low
    frequency, but two cycles are no period (a real rig's log was said to "repeat at 0.022 Hz
    ... a ramp up and down", and so was this before)."""
    t = np.arange(90 * 25) / 25.0
    pulses = 60.0 * sum(np.clip(1.0 - np.abs(t - centre) / 22.5, 0.0, None) for centre in (22.5, 67.5))
    assert "repeats" not in analyse(pulses, 25.0, K, A).sentence()


def test_an_overdamped_finger_has_no_resonance_and_a_slow_rate_shows_no_fast_band() -> None:
    """Damped about 300 times past critical and logged at 25 Hz: no "resonance", and no
    advice for content the rate cannot show."""
    rate = 25.0
    t = np.arange(int(60 * rate)) / rate
    steps = np.repeat(np.random.default_rng(1).uniform(0, 80, 30), int(2 * rate))[: t.size]
    damping = 300 * 2 * np.sqrt(K * A)
    sentence = analyse(steps, rate, K, A, damping).sentence()
    assert "resonance" not in sentence and "corner frequency" in sentence, sentence
    fast = analyse(steps, rate, 0.57, 1.6e-6).sentence()  # rings at 95 Hz, beyond 25 Hz sampling
    assert "95 Hz" not in fast and "beyond what this sample rate shows" in fast, fast
