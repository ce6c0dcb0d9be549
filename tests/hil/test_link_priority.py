"""The link's threads run one SCHED_FIFO priority below the tick that started them
(hand_service/transports/priority.py), so that a waking tick preempts them."""

from __future__ import annotations

import os
import threading

import pytest

from hand_service.transports.priority import below_tick


def _in_a_thread(policy_priority: int | None) -> tuple[int, int]:
    """Set the thread's own policy (SCHED_FIFO at `policy_priority`, or leave it), call
    below_tick() and return (policy, priority) as the thread then sees them."""
    seen: list[tuple[int, int]] = []
    errors: list[BaseException] = []

    def run() -> None:
        try:
            if policy_priority is not None:
                os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(policy_priority))
            below_tick()
            seen.append((os.sched_getscheduler(0), os.sched_getparam(0).sched_priority))
        except BaseException as exc:  # handed to the test's thread
            errors.append(exc)

    thread = threading.Thread(target=run)
    thread.start()
    thread.join()
    if errors:
        raise errors[0]
    return seen[0]


def test_a_link_thread_runs_one_priority_below_the_tick() -> None:
    try:
        policy, priority = _in_a_thread(20)
    except PermissionError:
        pytest.skip("SCHED_FIFO not permitted here")
    assert (policy, priority) == (os.SCHED_FIFO, 19)
    assert os.sched_getscheduler(0) == os.SCHED_OTHER  # the test's own thread is untouched


def test_an_ordinary_thread_is_left_as_it_is() -> None:
    assert _in_a_thread(None) == (os.SCHED_OTHER, 0)
