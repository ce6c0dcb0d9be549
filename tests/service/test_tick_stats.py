"""TickStats: what counts as a deadline miss, and which misses woke too late to be made."""

from __future__ import annotations

from hand_service.service.timing import TickStats

PERIOD_NS = 10_000_000


def test_a_miss_is_a_tick_that_ends_after_its_period() -> None:
    stats = TickStats(PERIOD_NS)
    deadline = 1_000_000_000
    assert not stats.add(deadline, deadline + 50_000, deadline + 9_000_000)  # on time
    assert stats.add(deadline, deadline + 2_000_000, deadline + 10_500_000)  # ran past its period
    assert stats.add(deadline, deadline + 14_000_000, deadline + 14_020_000)  # woke past it
    assert not stats.add(deadline, deadline, deadline + PERIOD_NS)  # ends on the next deadline
    summary = stats.summary()
    assert (summary["deadline_misses"], summary["deadline_misses_woke_late"]) == (2, 1)
    assert summary["jitter_us_max"] == 14_000.0 and summary["tick_ns_max"] == PERIOD_NS
