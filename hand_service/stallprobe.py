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

import numpy as np

START_DELAY_S = 1.0  # for every worker to start, pin itself and lock its memory
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


def _probe(cpu: int, start_ns: int, period_ns: int, n_ticks: int, priority: int | None,
           conn: Connection) -> None:
    """A worker: pinned to `cpu`, SCHED_FIFO and mlockall when permitted, the bare loop."""
    from rtcore import clock

    os.sched_setaffinity(0, {cpu})
    realtime = "normal scheduler"
    if priority is not None:
        try:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(priority))
            realtime = "SCHED_FIFO"
        except (PermissionError, OSError):
            pass
    clock.lock_memory()
    schedule = clock.Schedule(period_ns, start_ns)
    run = clock.floor_loop(schedule, n_ticks)
    conn.send((run.wake_late_ns, run.index, realtime))
    conn.close()


def probe(seconds: float, rate_hz: float, priority: int | None = 50,
          cpus: list[int] | None = None) -> tuple[list[int], list[np.ndarray], list[np.ndarray], list[str]]:
    """Run the bare loop on each CPU at once: (cpus, wake_late_ns, deadline index, realtime)
    per CPU. Workers are spawned (not forked) and always ended."""
    from rtcore import clock

    cpus = sorted(os.sched_getaffinity(0)) if cpus is None else cpus
    period_ns = round(1e9 / rate_hz)
    n_ticks = max(1, round(seconds * rate_hz))
    start_ns = clock.now_ns() + int(START_DELAY_S * 1e9)
    ctx = multiprocessing.get_context("spawn")
    workers, ends = [], []
    try:
        for cpu in cpus:
            receive, send = ctx.Pipe(duplex=False)
            worker = ctx.Process(target=_probe, args=(cpu, start_ns, period_ns, n_ticks, priority, send),
                                 name=f"stall-probe-cpu{cpu}", daemon=True)
            worker.start()
            send.close()
            workers.append(worker)
            ends.append(receive)
        results = [end.recv() for end in ends]
    finally:
        for worker in workers:
            if worker.is_alive():
                worker.join(timeout=seconds + START_DELAY_S + 5)
            if worker.is_alive():
                worker.kill()
                worker.join()
        for end in ends:
            end.close()
    late, index, realtime = (list(x) for x in zip(*results, strict=True))
    return cpus, late, index, realtime


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
