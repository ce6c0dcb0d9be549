"""Is this machine fit for a real-time loop? The bare C loop (rtcore_floor_loop) on every
CPU at once, on one absolute schedule, and each wake-up later than a threshold, matched
across CPUs: a stall seen on every CPU at the same instant means the whole machine
stopped (a virtual machine's host, firmware, an SMI), which no code and no CPU pinning
avoids; a stall on one CPU means that CPU was taken (an interrupt, a kernel thread,
another real-time task), which pinning and isolation can. Like rt-tests' cyclictest,
with the matching, and with nothing to install.
"""

from __future__ import annotations

import multiprocessing
import os
from dataclasses import dataclass
from multiprocessing.connection import Connection
from typing import Any

import numpy as np

from hand_service.errors import UserError

READY_TIMEOUT_S = 30.0  # for every worker to start, pin itself and lock its memory
START_DELAY_NS = 100_000_000  # from "all ready" to the common start: every worker takes it
STALL_NS = 1_000_000  # a wake-up this late (1 ms) or later is a stall


@dataclass
class Stall:
    """One stall: when it began (s from the start) and how late each CPU woke (ms; None
    on a CPU that did not see it)."""

    t_s: float
    late_ms: list[float | None]

    @property
    def every_cpu(self) -> bool:
        return all(x is not None for x in self.late_ms)


def _probe(cpu: int, period_ns: int, n_ticks: int, priority: int | None, conn: Connection) -> None:
    """A worker: pinned to `cpu`, SCHED_FIFO and mlockall when permitted; says it is ready,
    takes the common start, runs the bare loop and sends what it saw."""
    from rtcore import clock

    try:
        os.sched_setaffinity(0, {cpu})
    except OSError as exc:
        conn.send(f"cannot run there: {exc.strerror or exc}")
        return
    realtime = "normal scheduler"
    if priority is not None:
        try:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
            realtime = "SCHED_FIFO"
        except (PermissionError, OSError):
            pass
    clock.lock_memory()
    conn.send("ready")
    try:
        start_ns = conn.recv()
    except EOFError:  # the parent gave up (another worker failed)
        return
    if clock.now_ns() >= start_ns:  # a late start would read as a stall on every CPU
        conn.send(f"started {(clock.now_ns() - start_ns) / 1e6:.1f} ms after the common start")
        return
    run = clock.floor_loop(clock.Schedule(period_ns, start_ns), n_ticks)
    conn.send((run.wake_late_ns, run.index, realtime))
    conn.close()


def probe(seconds: float, rate_hz: float, priority: int | None = 50,
          cpus: list[int] | None = None) -> tuple[list[int], list[np.ndarray], list[np.ndarray], list[str]]:
    """Run the bare loop on each CPU at once: (cpus, wake_late_ns, deadline index, realtime)
    per CPU. Workers are spawned (not forked), start together once all are ready, and are
    always ended; a worker that fails ends the probe with one UserError."""
    from rtcore import clock

    cpus = sorted(os.sched_getaffinity(0)) if cpus is None else cpus
    period_ns = round(1e9 / rate_hz)
    n_ticks = max(1, round(seconds * rate_hz))
    ctx = multiprocessing.get_context("spawn")
    workers, ends = [], []
    try:
        for cpu in cpus:
            mine, theirs = ctx.Pipe()
            worker = ctx.Process(target=_probe, args=(cpu, period_ns, n_ticks, priority, theirs),
                                 name=f"stall-probe-cpu{cpu}", daemon=True)
            worker.start()
            theirs.close()
            workers.append(worker)
            ends.append(mine)
        for cpu, end in zip(cpus, ends, strict=True):
            _receive(end, cpu, READY_TIMEOUT_S)
        start_ns = clock.now_ns() + START_DELAY_NS
        for end in ends:
            end.send(start_ns)
        results = [_receive(end, cpu, seconds + READY_TIMEOUT_S) for cpu, end in zip(cpus, ends, strict=True)]
    finally:
        for end in ends:
            end.close()  # a worker blocked sending to a parent that gave up: EPIPE, it ends
        for worker in workers:
            worker.join(timeout=1.0)
            if worker.is_alive():
                worker.kill()
                worker.join()
    late, index, realtime = (list(x) for x in zip(*results, strict=True))
    return cpus, late, index, realtime


def _receive(end: Connection, cpu: int, timeout_s: float) -> Any:
    if not end.poll(timeout_s):
        raise UserError(f"the stall probe on CPU {cpu} did not answer within {timeout_s:g} s")
    try:
        message = end.recv()
    except EOFError:
        raise UserError(f"the stall probe on CPU {cpu} ended without a result") from None
    if isinstance(message, str) and message != "ready":
        raise UserError(f"the stall probe on CPU {cpu} {message}")
    return message


def match_stalls(late_ns: list[np.ndarray], index: list[np.ndarray], period_ns: int,
                 stall_ns: int = STALL_NS) -> list[Stall]:
    """Every wake-up at least stall_ns late, on any CPU, as [deadline, woke] intervals;
    intervals on different CPUs that overlap are one stall."""
    spans = []  # (start, end, cpu, late)
    for cpu, (late, idx) in enumerate(zip(late_ns, index, strict=True)):
        for k in np.flatnonzero(late >= stall_ns):
            begin = int(idx[k]) * period_ns
            spans.append((begin, begin + int(late[k]), cpu, int(late[k])))
    spans.sort()
    stalls: list[Stall] = []
    end_ns = -1
    for begin, end, cpu, late in spans:
        if not stalls or begin > end_ns:
            stalls.append(Stall(begin / 1e9, [None] * len(late_ns)))
            end_ns = end
        end_ns = max(end_ns, end)
        worst = stalls[-1].late_ms[cpu]
        stalls[-1].late_ms[cpu] = max(late / 1e6, worst or 0.0)
    return stalls


def summary(cpus: list[int], late_ns: list[np.ndarray], stalls: list[Stall], rate_hz: float,
            seconds: float, realtime: list[str]) -> dict[str, object]:
    return {
        "machine_cpus": cpus, "machine_rate_hz": rate_hz, "machine_seconds": seconds,
        "machine_realtime": sorted(set(realtime)),
        "machine_jitter_us_p50": [float(np.percentile(x, 50) / 1e3) for x in late_ns],
        "machine_jitter_us_p99": [float(np.percentile(x, 99) / 1e3) for x in late_ns],
        "machine_jitter_us_max": [float(x.max() / 1e3) for x in late_ns],
        "machine_stall_ms": STALL_NS / 1e6,
        "machine_stalls_every_cpu": sum(s.every_cpu for s in stalls),
        "machine_stalls_some_cpus": sum(not s.every_cpu for s in stalls),
        "machine_stalls": [{"t_s": s.t_s, "late_ms": s.late_ms} for s in stalls],
    }
