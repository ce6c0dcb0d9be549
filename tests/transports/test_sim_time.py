"""The simulated hand keeps time with the host's schedule: deadlines the host skipped pass
for the hand (its valves hold), except where the host says the time was not the hand's
(a benchmark's bare-loop blocks)."""

from __future__ import annotations

import numpy as np
import pytest

from hand_service.config.profile import load_profile
from hand_service.transports.sim import SimTransport


@pytest.fixture
def transport() -> SimTransport:
    sim = SimTransport(load_profile(None))
    sim.open()
    return sim


def _tick(sim: SimTransport, index: int) -> None:
    sim.on_tick(index)
    sim.latest()
    sim.send(np.full(sim.n_fingers, 20.0))


def test_skipped_deadlines_pass_for_the_hand(transport: SimTransport) -> None:
    period_s = 1.0 / transport.profile.control.rate_hz
    for i in range(3):
        _tick(transport, i)
    _tick(transport, 10)  # deadlines 3..9 skipped: the hand lived through them
    assert transport.simulator.time_s == pytest.approx(11 * period_s)


def test_resume_at_lets_the_schedule_jump_without_the_hand(transport: SimTransport) -> None:
    period_s = 1.0 / transport.profile.control.rate_hz
    for i in range(3):
        _tick(transport, i)
    transport.resume_at(10)
    _tick(transport, 10)
    assert transport.simulator.time_s == pytest.approx(4 * period_s)
