"""The supervisor's clock in C (csrc/rtcore_clock.c): CLOCK_MONOTONIC, absolute-deadline
sleep with an optional spin, the bare floor loop and memory locking.

    start = now_ns()
    index, deadline = 0, start
    woke = sleep_until_ns(deadline, spin_ns)   # never returns before the deadline
    ...                                        # the tick
    index, deadline = next_deadline(start, period, now_ns(), index)
"""

from __future__ import annotations

import errno
import os
from dataclasses import dataclass

import numpy as np

from rtcore._rtcore import ffi, lib

now_ns = lib.rtcore_clock_now_ns


def sleep_until_ns(deadline_ns: int, spin_ns: int = 0) -> int:
    """Sleep to an absolute CLOCK_MONOTONIC deadline (releasing the GIL); the wake time.

    Returns -EINTR when a signal woke it early, so that Python runs the signal handler
    before the caller sleeps again; raises OSError on any other error.
    """
    woke = lib.rtcore_sleep_until_ns(deadline_ns, spin_ns)
    if woke < 0:
        check_sleep(woke)
    return woke


def check_sleep(result: int) -> None:
    """A failed sleep's -errno: -EINTR (a signal woke it early; its handler has run by the
    time Python sees this) is for the caller to sleep again; anything else is an OSError."""
    if result != -errno.EINTR:
        raise OSError(-result, os.strerror(-result))


class Schedule:
    """Deadline k = start_ns + k·period_ns. After a miss it skips to the next deadline
    still ahead rather than running late ticks back to back."""

    def __init__(self, period_ns: int, start_ns: int | None = None) -> None:
        if period_ns <= 0:
            raise ValueError("the period must be positive")
        self.period_ns = int(period_ns)
        self.start_ns = int(now_ns() + period_ns if start_ns is None else start_ns)
        self.index = 0
        self._index = ffi.new("int64_t *")

    @property
    def deadline_ns(self) -> int:
        return self.start_ns + self.index * self.period_ns

    def advance(self, tick_end_ns: int) -> int:
        """Move past the tick that ended at tick_end_ns; returns the deadlines skipped."""
        self._index[0] = self.index
        lib.rtcore_next_deadline_ns(self.start_ns, self.period_ns, tick_end_ns, self._index)
        skipped = int(self._index[0]) - self.index - 1
        self.index = int(self._index[0])
        return skipped


@dataclass
class FloorRun:
    wake_late_ns: np.ndarray
    index: np.ndarray
    misses: int


def floor_loop(schedule: Schedule, n_ticks: int, spin_ns: int = 0) -> FloorRun:
    """The bare C loop for n_ticks on `schedule`, from its current deadline, which it
    advances: the machine's own wake-up floor, measured in the caller's run."""
    late = np.zeros(n_ticks, dtype=np.int64)
    index = np.zeros(n_ticks, dtype=np.int64)
    misses = ffi.new("int32_t *")
    next_index = lib.rtcore_floor_loop(
        schedule.start_ns, schedule.period_ns, schedule.index, n_ticks, spin_ns,
        ffi.cast("int64_t *", ffi.from_buffer(late)), ffi.cast("int64_t *", ffi.from_buffer(index)),
        misses)
    if next_index < 0:
        raise ValueError("floor_loop: bad arguments")
    schedule.index = int(next_index)
    return FloorRun(late, index, int(misses[0]))


def lock_memory() -> int:
    """mlockall(MCL_CURRENT | MCL_FUTURE): 0, or the errno when not permitted."""
    return int(lib.rtcore_lock_memory())


def unlock_memory() -> int:
    return int(lib.rtcore_unlock_memory())
