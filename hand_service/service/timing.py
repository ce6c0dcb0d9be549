"""Tick timing: wake-up jitter, tick duration and deadline misses per tick, kept in
preallocated arrays; and the process set-up a real-time loop wants (SCHED_FIFO,
mlockall, the garbage collector kept out of the tick, a short GIL switch interval)."""

from __future__ import annotations

import contextlib
import gc
import logging
import os
import sys
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from rtcore import clock

log = logging.getLogger(__name__)

WINDOW = 1 << 16  # ticks kept for percentiles: 11 min at 100 Hz, 65 s at 1 kHz
# How long another thread may hold the GIL while the tick waits for it (CPython's default
# is 5 ms). Every cffi call in the tick releases the GIL and takes it back, so behind a
# busy Python thread a tick waited up to this long many times over (docs/service.md).
SWITCH_INTERVAL_S = 1e-4


class TickStats:
    """Per tick: how late it woke (jitter) and how long it ran; totals since start."""

    def __init__(self, period_ns: int, window: int = WINDOW) -> None:
        self.period_ns = period_ns
        self.wake_late_ns = np.zeros(window, dtype=np.int64)
        self.tick_ns = np.zeros(window, dtype=np.int64)
        self.window = window
        self.ticks = 0
        self.misses = 0
        self.misses_woke_late = 0  # of the misses: woke after its period had ended already
        self.skipped = 0
        self.jitter_max_ns = 0
        self.tick_max_ns = 0
        # a tick that ends in C (the simulated hand): from its end until Python runs again
        self.return_ns = np.zeros(window, dtype=np.int64)
        self.returns = 0

    def add_return(self, ns: int) -> None:
        self.return_ns[self.returns % self.window] = ns
        self.returns += 1

    def add(self, deadline_ns: int, woke_ns: int, end_ns: int) -> bool:
        """Record one tick; returns whether it missed its deadline (ended after its period)."""
        i = self.ticks % self.window
        late = woke_ns - deadline_ns
        ran = end_ns - woke_ns
        self.wake_late_ns[i] = late
        self.tick_ns[i] = ran
        self.ticks += 1
        if late > self.jitter_max_ns:
            self.jitter_max_ns = late
        if ran > self.tick_max_ns:
            self.tick_max_ns = ran
        missed = end_ns > deadline_ns + self.period_ns
        if missed:
            self.misses += 1
            if late >= self.period_ns:  # no tick, however short, could have made it
                self.misses_woke_late += 1
        return missed

    def recent(self, last: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """The last `last` ticks (default: all kept), oldest first."""
        n = min(self.ticks, self.window, last or self.window)
        idx = (np.arange(self.ticks - n, self.ticks)) % self.window
        return self.wake_late_ns[idx], self.tick_ns[idx]

    def summary(self, last: int | None = None) -> dict[str, float | int]:
        late, ran = self.recent(last)
        if late.size == 0:
            return {"ticks": 0, "deadline_misses": 0, "deadline_misses_woke_late": 0}
        j50, j99 = np.percentile(late, [50, 99]) / 1e3
        t50, t99 = np.percentile(ran, [50, 99])
        return {"ticks": self.ticks, "tick_ns_p50": float(t50), "tick_ns_p99": float(t99),
                "tick_ns_max": int(self.tick_max_ns), "jitter_us_p50": float(j50),
                "jitter_us_p99": float(j99), "jitter_us_max": self.jitter_max_ns / 1e3,
                "deadline_misses": self.misses, "deadline_misses_woke_late": self.misses_woke_late,
                "skipped_deadlines": self.skipped,
                "window_ticks": int(late.size), **self._return_summary(last)}

    def _return_summary(self, last: int | None) -> dict[str, float]:
        n = min(self.returns, self.window, last or self.window)
        if n == 0:
            return {}
        back = self.return_ns[np.arange(self.returns - n, self.returns) % self.window]
        r50, r99 = np.percentile(back, [50, 99])
        return {"tick_return_ns_p50": float(r50), "tick_return_ns_p99": float(r99)}


@dataclass
class Realtime:
    """What the process got: each is None when not asked for, else True or the reason."""

    sched_fifo: bool | str | None = None
    memory_locked: bool | str | None = None

    def describe(self) -> str:
        def one(name: str, value: bool | str | None) -> str:
            return f"{name} {'on' if value is True else 'off' if value is None else 'unavailable'}"
        return ", ".join([one("SCHED_FIFO", self.sched_fifo), one("mlockall", self.memory_locked)])


def setup_realtime(priority: int | None, lock_memory: bool) -> Realtime:
    """SCHED_FIFO at `priority` and mlockall when permitted; a clear warning when not."""
    result = Realtime()
    if priority is not None:
        try:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
            result.sched_fifo = True
        except (PermissionError, OSError, AttributeError) as exc:
            result.sched_fifo = str(exc)
            log.warning("SCHED_FIFO priority %d not permitted (%s): running with the normal "
                        "scheduler. Grant it with CAP_SYS_NICE or an rtprio limit "
                        "(systemd: LimitRTPRIO=%d; see docs/service.md)", priority, exc, priority)
    if lock_memory:
        code = clock.lock_memory()
        if code == 0:
            result.memory_locked = True
        else:
            result.memory_locked = os.strerror(code)
            log.warning("mlockall not permitted (%s): memory may be paged out. Raise the "
                        "memlock limit (systemd: LimitMEMLOCK=infinity; see docs/service.md)",
                        os.strerror(code))
    return result


@contextlib.contextmanager
def switch_interval(seconds: float = SWITCH_INTERVAL_S) -> Iterator[None]:
    """sys.setswitchinterval(seconds) while the loop runs; the old value after."""
    old = sys.getswitchinterval()
    sys.setswitchinterval(seconds)
    try:
        yield
    finally:
        sys.setswitchinterval(old)


class GcControl:
    """The collector stays out of the tick: disabled, everything alive at start frozen,
    and the young generations collected in the slack once per `every_s`."""

    def __init__(self, rate_hz: float, every_s: float = 1.0) -> None:
        self.every_ticks = max(1, round(every_s * rate_hz))
        self.min_slack_ns = int(min(2e6, 0.5e9 / rate_hz))
        self.collections = 0
        self.collect_ns_max = 0
        self._was_enabled = gc.isenabled()

    def start(self) -> None:
        gc.collect()
        gc.freeze()
        gc.disable()

    def maybe_collect(self, tick: int, slack_ns: int) -> None:
        """In the slack after tick `tick`, when at least 2 ms (or half a period) is left."""
        if tick % self.every_ticks or slack_ns < self.min_slack_ns:
            return
        t0 = clock.now_ns()
        gc.collect(1)
        self.collect_ns_max = max(self.collect_ns_max, clock.now_ns() - t0)
        self.collections += 1

    def stop(self) -> None:
        gc.unfreeze()
        if self._was_enabled:
            gc.enable()
