"""The refused-token warning (api/refusal_log.py): one line per interval, the rest counted."""

from __future__ import annotations

import logging

import pytest

from hand_service.api.refusal_log import RefusalLog


def test_refusals_within_the_interval_are_counted_in_the_next_line(caplog: pytest.LogCaptureFixture) -> None:
    log = logging.getLogger("test.refusals")
    refusals = RefusalLog(log, interval_s=10.0)
    with caplog.at_level("WARNING", logger="test.refusals"):
        for i in range(100):  # 100 a second for a second
            refusals.refused("tcp:1", now_s=i * 0.01)
        refusals.refused("tcp:2", now_s=10.5)
    lines = [r.getMessage() for r in caplog.records]
    assert len(lines) == 2, lines
    assert "99 more refused" in lines[1] and "tcp:2" in lines[1]
