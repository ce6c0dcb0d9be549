"""The absolute schedule in C: deadlines never drift, a miss skips ahead, the sleep never
returns early, and the bare floor loop reports what it measured."""

from __future__ import annotations

import numpy as np

from rtcore import clock


def test_deadlines_are_absolute_whatever_a_tick_costs() -> None:
    s = clock.Schedule(period_ns=1_000_000, start_ns=5_000_000_000)
    ends = [5_000_000_000 + 300_000, 5_001_000_000 + 900_000, 5_002_000_000 + 10]
    for k, end in enumerate(ends):
        assert s.deadline_ns == 5_000_000_000 + k * 1_000_000
        assert s.advance(end) == 0
    assert s.deadline_ns == 5_003_000_000


def test_a_miss_skips_to_the_next_deadline_ahead() -> None:
    s = clock.Schedule(period_ns=1_000_000, start_ns=0)
    assert s.advance(3_500_000) == 3  # tick 0 ended after deadlines 1, 2 and 3: all skipped
    assert s.index == 4 and s.deadline_ns == 4_000_000
    assert s.advance(4_000_000) == 0  # ending exactly on deadline 5 is not a skip
    assert s.index == 5


def test_sleep_never_returns_before_its_deadline() -> None:
    for spin_ns in (0, 200_000):
        for _ in range(20):
            deadline = clock.now_ns() + 300_000
            woke = clock.sleep_until_ns(deadline, spin_ns)
            assert woke >= deadline
            assert clock.now_ns() >= deadline


def test_floor_loop_follows_the_schedule() -> None:
    s = clock.Schedule(period_ns=2_000_000)
    first = s.index
    run = clock.floor_loop(s, 25)
    assert run.wake_late_ns.shape == (25,)
    assert np.all(run.wake_late_ns >= 0)
    assert np.all(np.diff(run.index) >= 1) and run.index[0] == first
    assert s.index > run.index[-1]
    assert run.misses == int(np.sum(run.wake_late_ns > s.period_ns))


def test_memory_locking_answers() -> None:
    code = clock.lock_memory()
    assert isinstance(code, int)
    if code == 0:
        assert clock.unlock_memory() == 0
