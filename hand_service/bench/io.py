"""I/O benchmarks against the mock firmware, per transport (measured, never asserted).

- Command -> sensor round trip: from send() of a valve command to the arrival of the
  first sensor sample whose command_sequence shows the firmware held it. The firmware
  samples on its own 100 Hz clock and commands go out at a random phase, so the figure
  includes on average half a sample period of waiting, as a controller sees it.
- Host death -> vent: a host holding pressure is SIGKILLed (virtual bus: its thread
  stops), and the firmware's watchdog vent is timed on the machine's monotonic clock,
  which every process shares. The bound is the watchdog time plus one frame.
"""

from __future__ import annotations

import logging
import os
import random
import signal
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from hand_service.firmware.hold import hold
from hand_service.firmware.rig import RIG_PROFILES, Rig

WAIT_S = 5.0


def _percentiles(name: str, what: str, values_ms: np.ndarray) -> dict[str, float]:
    p50, p99 = np.percentile(values_ms, [50, 99])
    return {f"io_{name}_{what}_ms_p50": float(p50), f"io_{name}_{what}_ms_p99": float(p99),
            f"io_{name}_{what}_ms_max": float(values_ms.max())}


def round_trips_ms(rig: Rig, commands: int, seed: int = 1) -> np.ndarray:
    rng = random.Random(seed)
    transport = rig.transport()
    transport.open()
    period_s = 1.0 / rig.profile.control.rate_hz
    command = np.full(transport.n_fingers, 20.0)
    out = []
    for _ in range(commands):
        end = time.monotonic() + WAIT_S
        while transport.latest() is None and time.monotonic() < end:
            time.sleep(0.0005)
        time.sleep(rng.uniform(0.0, period_s))
        sent_s = time.monotonic()
        transport.send(command)
        sequence = transport.command_sequence
        while time.monotonic() < sent_s + WAIT_S:
            sample = transport.latest()
            if sample is not None and sample.command_sequence >= sequence:
                out.append((sample.received_s - sent_s) * 1e3)
                break
            time.sleep(0.0002)
    transport.close()
    return np.array(out)


def _wait_for_vents(rig: Rig, count: int) -> list[float]:
    end = time.monotonic() + WAIT_S
    while len(rig.vent_times_s()) < count and time.monotonic() < end:
        time.sleep(0.002)
    return rig.vent_times_s()


def vent_latencies_ms(rig: Rig, trials: int) -> np.ndarray:
    out = []
    watchdog_s = rig.profile.safety["firmware_watchdog_ms"] / 1e3
    for _ in range(trials):
        seen = len(rig.vent_times_s())
        if rig.in_process:
            transport = rig.transport()
            transport.open()
            stop = threading.Event()
            thread = threading.Thread(target=hold, args=(transport, 40.0, stop), daemon=True)
            thread.start()
            time.sleep(0.3)
            died_s = time.monotonic()
            stop.set()
            thread.join()
            transport.close()
        else:
            host = rig.start_host(40.0)
            time.sleep(0.3)
            died_s = time.monotonic()
            os.kill(host.pid, signal.SIGKILL)
            host.wait()
        vents = [t for t in _wait_for_vents(rig, seen + 1)[seen:] if t > died_s - watchdog_s]
        if vents:
            out.append((vents[0] - died_s) * 1e3)
    return np.array(out)


def run_io_bench(quick: bool = False, trials: int | None = None, commands: int | None = None,
                 progress: bool = True) -> dict[str, float | int | str]:
    trials = trials or (5 if quick else 30)
    commands = commands or (100 if quick else 500)
    results: dict[str, float | int | str] = {}
    quiet = logging.getLogger("hand_service")
    level = quiet.level
    quiet.setLevel(logging.ERROR)  # every trial vents on purpose: no warnings for that
    try:
        _run(results, trials, commands, progress)
    finally:
        quiet.setLevel(level)
    results["io_vent_trials"] = trials
    results["io_round_trip_commands"] = commands
    return results


def _run(results: dict[str, float | int | str], trials: int, commands: int, progress: bool) -> None:
    with tempfile.TemporaryDirectory(prefix="hand-iobench-") as workdir:
        for name in sorted(RIG_PROFILES):
            with Rig(name, Path(workdir)) as rig:
                rig.start_mock()
                watchdog_ms = rig.profile.safety["firmware_watchdog_ms"]
                bound_ms = watchdog_ms + 1e3 / rig.profile.control.rate_hz
                if progress:
                    print(f"  {name}: {commands} round trips, {trials} host deaths ...", flush=True)
                rtt = _percentiles(name, "round_trip", round_trips_ms(rig, commands))
                _wait_for_vents(rig, 1)  # the round-trip host has gone: its vent comes first
                vent = _percentiles(name, "vent_latency", vent_latencies_ms(rig, trials))
                results.update(rtt)
                results.update(vent)
                results[f"io_{name}_vent_bound_ms"] = bound_ms
                results[f"io_{name}_vent_p99_within_bound"] = int(vent[f"io_{name}_vent_latency_ms_p99"]
                                                                 <= bound_ms)
                if progress:
                    print(f"    command -> sensor round trip  p50 "
                          f"{rtt[f'io_{name}_round_trip_ms_p50']:6.2f} ms   p99 "
                          f"{rtt[f'io_{name}_round_trip_ms_p99']:6.2f} ms")
                    print(f"    host death -> vent            p50 "
                          f"{vent[f'io_{name}_vent_latency_ms_p50']:6.1f} ms   p99 "
                          f"{vent[f'io_{name}_vent_latency_ms_p99']:6.1f} ms   (bound {bound_ms:.0f} ms: "
                          f"watchdog {watchdog_ms:.0f} ms + one frame)")
