"""Structure that grows with the finger's motion (residual/motion_structure.py) on synthetic
misfits; on the independent truth's pressure damping: test_pressure_damping_outside.py."""

from __future__ import annotations

import numpy as np

from hand_service.diagnose.residual import motion_structure

RATE_HZ = 200.0
DURATION_S = 30.0
NOISE_DEG = 0.2


def correlated_noise(n: int, seed: int) -> np.ndarray:
    """A lab sensor's noise: white beside first-order noise correlated over 0.2 s, NOISE_DEG RMS."""
    rng = np.random.default_rng(seed)
    pole = np.exp(-1.0 / (0.2 * RATE_HZ))
    shocks = rng.normal(0.0, np.sqrt(1.0 - pole**2), n)
    slow = np.zeros(n)
    for i in range(1, n):
        slow[i] = pole * slow[i - 1] + shocks[i]
    return NOISE_DEG * (0.8 * slow + 0.6 * rng.normal(0.0, 1.0, n))


def chirp_angle_deg(n: int) -> np.ndarray:
    """A finger swept 0.2 to 5 Hz at a constant amplitude: its speed grows along the sweep."""
    t = np.arange(n) / RATE_HZ
    return 20.0 * np.sin(2.0 * np.pi * (0.2 * t + 0.5 * (5.0 - 0.2) * t**2 / DURATION_S))


def test_noise_does_not_grow_with_the_motion() -> None:
    n = int(DURATION_S * RATE_HZ)
    angle = chirp_angle_deg(n)
    everywhere = np.ones(n, dtype=bool)
    for seed in range(5):
        got = motion_structure.motion_structure(correlated_noise(n, seed), angle, everywhere, RATE_HZ)
        assert got is not None and got.windows == int(DURATION_S)
        assert got.fast_speed_deg_s > 3.0 * got.slow_speed_deg_s
        assert got.ratio < 1.5 and not got.exceeded


def test_a_missing_damping_grows_with_the_motion() -> None:
    """A misfit in proportion to the speed, twice the noise over the recording."""
    n = int(DURATION_S * RATE_HZ)
    angle = chirp_angle_deg(n)
    speed = np.gradient(angle) * RATE_HZ
    torque_like = 2.0 * NOISE_DEG * speed / np.sqrt(np.mean(speed**2))
    everywhere = np.ones(n, dtype=bool)
    got = motion_structure.motion_structure(torque_like + correlated_noise(n, 7), angle, everywhere, RATE_HZ)
    assert got is not None and got.exceeded
    assert "grows with the finger's motion" in got.sentence()


def test_a_short_recording_gives_no_figure() -> None:
    n = int(5.0 * RATE_HZ)
    got = motion_structure.motion_structure(correlated_noise(n, 3), chirp_angle_deg(n), np.ones(n, bool),
                                            RATE_HZ)
    assert got is None
