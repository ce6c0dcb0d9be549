"""Evidence sentences say what this recording shows: no free swings where there were none."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from hand_service.diagnose.evidence import Context, _coulomb

RATE_HZ = 100.0
T = np.arange(int(10 * RATE_HZ)) / RATE_HZ


def _context(pressure_kpa: np.ndarray, velocity_deg_per_s: np.ndarray) -> Context:
    problem = SimpleNamespace(pressure_kpa=pressure_kpa, rate_hz=RATE_HZ)
    return Context(problem, np.zeros_like(T), velocity_deg_per_s, 0.57, 0.003, 0.01)  # type: ignore[arg-type]


def test_steps_without_free_swings_are_not_said_to_have_them() -> None:
    steps = np.repeat([10.0, 60.0, 20.0, 80.0], T.size // 4)
    velocity = np.where(np.abs(np.diff(steps, prepend=steps[0])) > 0, 300.0, 0.0)  # moves, then rests
    text = _coulomb(_context(steps, velocity))
    assert "free swings" not in text and "nearly still" in text and "0.01 N·m" in text


def test_a_release_is_a_free_swing() -> None:
    velocity = 200.0 * np.exp(-T) * np.sin(2 * np.pi * 9.5 * T)  # ringing at rest pressure
    text = _coulomb(_context(np.zeros(T.size), velocity))
    assert "free swings lose about 4 deg" in text
