"""Tick timing of the whole supervisor against the machine's own floor, in one run.

Blocks of one second alternate on ONE absolute schedule: the supervisor (tracking the
sweep on the simulated hand, recording every tick) and the bare C loop
(rtcore_floor_loop: clock_nanosleep to the same deadlines, nothing else). Both see the
same machine at nearly the same moments, so the supervisor is judged as a ratio to the
floor (docs/formats.md, `bench`). Over a bus (a transport to a mock firmware) the blocks are
a few ticks long, so that the firmware's watchdog and the stale-sample check never see
the bare loop's silence (block_ticks).
"""

from __future__ import annotations

import math
import tempfile
import time
from pathlib import Path

import numpy as np

from hand_service.commands.progress import Progress
from hand_service.config.at_rate import with_rate
from hand_service.config.profile import Profile
from hand_service.errors import UserError
from hand_service.service.factory import supervisor
from hand_service.service.recorder import Recorder
from hand_service.service.states import State
from hand_service.service.timing import SWITCH_INTERVAL_S, setup_realtime, switch_interval
from hand_service.service.trajectory import CosineSweep, Trajectory
from hand_service.transports import Transport, transport_class
from rtcore import clock
from rtcore.can import PHASES, CanTickCore

HANDSHAKE_TIMEOUT_S = 10.0


def sweep_trajectory(n_fingers: int, rate_hz: float) -> Trajectory:
    n = round(CosineSweep().period_s * 4 * rate_hz)
    traj = Trajectory.empty(n, n_fingers, rate_hz, "bench sweep")
    refs = CosineSweep().at(np.arange(n) / rate_hz)
    for i in range(n_fingers):
        traj.set_position(slice(None), i, refs)
    return traj


def block_ticks(profile: Profile, rate_hz: float) -> int:
    """Ticks per block: one second on the simulated hand. Over a bus the firmware runs on
    its own clock while the bare loop runs, so a block must end well inside its watchdog
    (no command for firmware_watchdog_ms: it vents) and inside the samples the supervisor
    may miss in a row (stale_sensor_ticks)."""
    if profile.transport["kind"] == "sim":
        return max(1, round(rate_hz))
    watchdog_ticks = profile.safety["firmware_watchdog_ms"] / 1e3 * rate_hz
    return max(1, min(int(watchdog_ticks / 2), profile.safety["stale_sensor_ticks"] - 2))


def bus_batch(transport: Transport) -> CanTickCore | None:
    """The batch and C tick of a transport that ticks in C over can-v1 (its phases are read
    after every tick), or None (the simulated hand, serial-v1, --tick-in-python)."""
    state = getattr(transport, "tick_state", None)
    return None if state is None else state.batch


def phase_figures(phase_ns: list[tuple[int, ...]]) -> dict[str, float | None]:
    """p50, p99 and max of each phase of the C tick over can-v1 (tick_decode_ns_p50, ...);
    None for each when the tick did not run in C over can-v1."""
    table = np.array(phase_ns, dtype=np.float64).reshape(-1, len(PHASES))
    figures: dict[str, float | None] = {}
    for k, name in enumerate(PHASES):
        column = table[:, k]
        for label, value in (("p50", 50.0), ("p99", 99.0), ("max", 100.0)):
            figures[f"tick_{name}_ns_{label}"] = float(np.percentile(column, value)) if column.size else None
    return figures


def measure_ticks(profile: Profile, rate_hz: float, seconds: float, spin_us: float = 0.0,
                  recorder: str | None = "process", realtime_priority: int | None = 50,
                  progress: bool = False, transport: Transport | None = None,
                  switch_interval_s: float = SWITCH_INTERVAL_S,
                  record_sync_s: float | None = None, foxglove_port: int | None = None) -> dict[str, object]:
    """`transport`: a bus transport to a (mock) firmware; default: the profile's own, which
    for the sim transport is the in-process simulated hand. `switch_interval_s`: the GIL
    switch interval while ticking (the daemon's by default). `record_sync_s`: the writer also
    fdatasyncs that often (run --record-sync-s). `foxglove_port`: also serve the recording to
    Foxglove there (run --foxglove's server, a process beside). `progress`: say how far it is on stderr
    through commands.progress (a bar on a terminal, a plain line every 2 s elsewhere)."""
    profile = with_rate(profile, rate_hz)
    if transport is None:
        transport = transport_class(profile.transport["kind"])(profile)
    rec = Recorder(profile.finger_names, rate_hz, recorder or "process", record_sync_s)
    sup = supervisor(profile, transport, rec, spin_us=spin_us)
    tmp = tempfile.TemporaryDirectory(prefix="hand-service-bench-")
    beside = None
    if recorder:
        rec.start(Path(tmp.name) / "bench.csv", {"bench": "tick"})
        if foxglove_port is not None:
            from hand_service.view.beside import start_beside

            beside = start_beside(["hand_service.view.foxglove", "--ring", str(rec.status()["ring_path"]),
                                   "--fingers", ",".join(profile.finger_names), "--rate", f"{rate_hz:g}",
                                   "--port", str(foxglove_port)])
    sup.set_trajectory(sweep_trajectory(len(profile.fingers), rate_hz), loop=True)
    # as the daemon runs (run locks memory unless --no-mlock): both loops, no page faults
    realtime = setup_realtime(realtime_priority, lock_memory=realtime_priority is not None)
    block = block_ticks(profile, rate_hz)
    n_ticks = max(block, round(seconds * rate_hz))
    spin_ns = int(spin_us * 1000)
    schedule = clock.Schedule(sup.period_ns)
    floor_late: list[np.ndarray] = []
    floor_misses = 0
    cpu_sup_s = cpu_floor_s = 0.0
    # the simulated hand's period, simulated in the slack after each tick
    timed = sup.time_hand_advance()
    plant_ns: list[int] = [] if timed is None else timed
    shown = Progress("bench", total=n_ticks, quiet=not progress)
    batch: CanTickCore | None = None
    phase_ns: list[tuple[int, ...]] = []  # per tick over can-v1 in C: its phases (PHASES)
    try:
        with shown, switch_interval(switch_interval_s), sup.stepping("bench done"):
            handshake_end_s = time.monotonic() + HANDSHAKE_TIMEOUT_S
            while sup.state is not State.DISARMED:  # the handshake, not measured
                if sup.state is State.FAULT or time.monotonic() > handshake_end_s:
                    faults = sup.fault_history().faults
                    why = f"{faults[-1].cause.value}: {faults[-1].detail}" if faults else "no answer"
                    raise UserError(f"the firmware did not come up within {HANDSHAKE_TIMEOUT_S:g} s "
                                    f"({sup.state.name}, {why})")
                sup.run_one(schedule)
            sup.arm()
            sup.start()
            for _ in range(max(1, round(rate_hz / 4))):  # settle
                sup.run_one(schedule)
            sup.reset_timing()
            plant_ns.clear()
            batch = bus_batch(transport)  # bound by now (the supervisor's first tick in C)
            done = 0
            while done < n_ticks:
                count = min(block, n_ticks - done)
                c0 = time.thread_time()
                for _ in range(count):
                    in_c = batch is not None and sup.state is not State.INIT  # INIT: the handshake
                    sup.run_one(schedule)
                    if in_c and batch is not None:
                        phase_ns.append(batch.phase_ns)
                c1 = time.thread_time()
                run = clock.floor_loop(schedule, count, spin_ns)
                transport.resume_at(schedule.index)
                cpu_sup_s += c1 - c0
                cpu_floor_s += time.thread_time() - c1
                floor_late.append(run.wake_late_ns)
                floor_misses += run.misses
                done += count
                if done // rate_hz > (done - count) // rate_hz or done == n_ticks:  # a second on
                    shown.advance(done - shown.count, f"{done / rate_hz:.0f} of {n_ticks / rate_hz:g} s "
                                  "ticked (and as long for the bare loop)")
    finally:
        if beside is not None:
            from hand_service.view.beside import stop_view

            stop_view(beside)
        tmp.cleanup()
        if realtime.memory_locked is True:
            clock.unlock_memory()
    s = sup.timing()
    floor = np.concatenate(floor_late) / 1e3
    busy_s = n_ticks / rate_hz
    return {
        "rate_hz": rate_hz, "ticks": s["ticks"], "ticks_floor": int(floor.size),
        "tick_ns_p50": s["tick_ns_p50"], "tick_ns_p99": s["tick_ns_p99"], "tick_ns_max": s["tick_ns_max"],
        "jitter_us_p50": s["jitter_us_p50"], "jitter_us_p99": s["jitter_us_p99"],
        "jitter_us_max": s["jitter_us_max"],
        "jitter_floor_us_p50": float(np.percentile(floor, 50)),
        "jitter_floor_us_p99": float(np.percentile(floor, 99)),
        "jitter_floor_us_max": float(floor.max()),
        "deadline_misses": s["deadline_misses"], "deadline_misses_floor": floor_misses,
        "deadline_misses_woke_late": s["deadline_misses_woke_late"],
        "skipped_deadlines": s["skipped_deadlines"], "spin_us": spin_us,
        "cpu_percent": 100.0 * cpu_sup_s / busy_s, "cpu_percent_floor": 100.0 * cpu_floor_s / busy_s,
        "recorder": recorder or "off", "record_sync_s": record_sync_s,
        "faults": sup.fault_history().total,
        "realtime": realtime.describe(),
        "switch_interval_us": switch_interval_s * 1e6,
        "tick_return_ns_p50": s.get("tick_return_ns_p50"), "tick_return_ns_p99": s.get("tick_return_ns_p99"),
        "plant_ns_p50": float(np.percentile(plant_ns, 50)) if plant_ns else None,
        "plant_ns_p99": float(np.percentile(plant_ns, 99)) if plant_ns else None,
        **phase_figures(phase_ns),
        "jitter_ratio_p99": (s["jitter_us_p99"] / float(np.percentile(floor, 99))
                             if np.percentile(floor, 99) > 0 else math.nan),
    }
