"""What a bus transport checks in every sample and heartbeat, with counters and log lines.

Sequence gaps (lost samples), late samples (the firmware's stream stalled), sensors
outside the board's ADC range or stuck on one reading, firmware reboots and vents. The
counters only count and log. The link checks (checks.py) it feeds name a LinkProblem
for the supervisor to fault on: deciding to stop is the supervisor's job.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field

import numpy as np

from hand_service.transports.base import SensorSample, TransportHealth
from hand_service.transports.checks import LinkChecks, LinkLimits
from hand_service.wire.messages import FirmwareState, SensorReport, Status, fault_name, sequence_delta

log = logging.getLogger("hand_service.transports")


@dataclass
class RateLimitedLog:
    """At most one line per key per interval; the lines held back are counted in the next."""

    interval_s: float = 1.0
    _last: dict[str, float] = field(default_factory=dict)
    _held: dict[str, int] = field(default_factory=dict)

    def warning(self, key: str, message: str) -> None:
        now = time.monotonic()
        if now - self._last.get(key, -1e9) < self.interval_s:
            self._held[key] = self._held.get(key, 0) + 1
            return
        held = self._held.pop(key, 0)
        self._last[key] = now
        log.warning("%s%s", message, f" ({held} more like it held back)" if held else "")


class SampleMonitor:
    """Turns SensorReports into SensorSamples, counting everything that looks wrong."""

    def __init__(self, finger_names: list[str], settings: dict, stale_s: float,
                 health: TransportHealth, limits: LinkLimits | None = None) -> None:
        self.names = finger_names
        self.checks = LinkChecks(limits or LinkLimits.defaults())
        self.sensor_min_mv = settings["sensor_min_mv"]
        self.sensor_max_mv = settings["sensor_max_mv"]
        self.stuck_samples = settings["stuck_samples"]
        self.stale_s = stale_s
        self.health = health
        self.log = RateLimitedLog()
        for key in ("host_stalls", "host_stall_lost_samples",
                    "late_samples", "duplicate_samples", "sensor_out_of_range", "stuck_sensor",
                    "firmware_reboots", "firmware_vents", "firmware_faults"):
            health.extra.setdefault(key, 0)
        n = len(finger_names)
        self._out_of_range = np.zeros(n, dtype=bool)
        self._same_run = np.zeros(n, dtype=np.int64)
        self._previous_mv: np.ndarray | None = None
        self._last_sequence: int | None = None
        self._sequence = -1  # unwrapped
        self._last_sample_s: float | None = None
        self._uptime_ms: int | None = None
        self._state: FirmwareState | None = None
        self._fault_code = 0
        self.vents = 0  # vents of the firmware's own: FirmwareStatus.vents

    def begin(self) -> None:
        """The host opens the link: nothing before counts."""
        self._last_sequence = None
        self._last_sample_s = None
        self.checks.begin()

    def restart(self) -> None:
        """The stream starts over (a reconnect or a reboot): no sequence gap is counted across
        it, but the wait for the next sample still is: a late sample is late however it ends."""
        self._last_sequence = None
        self.checks.restart()

    def sample(self, report: SensorReport, now: float, last_command: int) -> SensorSample | None:
        h = self.health
        lost = 0
        if self._last_sequence is not None:
            delta = sequence_delta(report.sequence, self._last_sequence)
            if delta == 0 or delta >= 128:
                h.extra["duplicate_samples"] += 1
                if delta == 0:
                    self.checks.same_sequence(report.sequence)
                return None
            lost = delta - 1
            if delta > 1:
                h.sequence_gaps += delta - 1
                self.log.warning("gap", f"sensor sequence gap: {delta - 1} sample(s) lost "
                                 f"(sequence {self._last_sequence} -> {report.sequence})")
            self._sequence += delta
        else:
            self._sequence += 1
        if self._last_sample_s is not None and now - self._last_sample_s > self.stale_s:
            h.extra["late_samples"] += 1
            self.log.warning("late", f"no sensor sample for {(now - self._last_sample_s) * 1e3:.0f} ms "
                             f"(stale after {self.stale_s * 1e3:.0f} ms)")
        self._last_sequence = report.sequence
        self._last_sample_s = now
        acked = (last_command - sequence_delta(last_command, report.command_sequence)
                 if last_command > 0 else -1)
        excused = self.checks.excused(now)
        self.checks.sample(self._sequence, lost, now, acked)
        if excused:  # the host's own stall, ridden through: not the link's loss
            h.extra["host_stall_lost_samples"] += lost
            lost = 0
        mv = np.array(report.sensor_mv, dtype=np.float64)
        self._check_sensors(mv)
        return SensorSample(self._sequence, now, mv, np.array(report.pressure_meas_kpa, dtype=np.float64),
                            acked, lost)

    def _check_sensors(self, mv: np.ndarray) -> None:
        bad = (mv < self.sensor_min_mv) | (mv > self.sensor_max_mv)
        for i in np.flatnonzero(bad & ~self._out_of_range):
            self.health.extra["sensor_out_of_range"] += 1
            log.warning("finger %s: sensor reads %.1f mV, outside the board's range %g..%g mV",
                        self.names[i], mv[i], self.sensor_min_mv, self.sensor_max_mv)
        self._out_of_range = bad
        if self.stuck_samples and self._previous_mv is not None:
            same = mv == self._previous_mv
            self._same_run = np.where(same, self._same_run + 1, 0)
            for i in np.flatnonzero(self._same_run == self.stuck_samples):
                self.health.extra["stuck_sensor"] += 1
                log.warning("finger %s: sensor stuck at %.1f mV for %d samples", self.names[i], mv[i],
                            self.stuck_samples + 1)
        self._previous_mv = mv

    def turn(self, now: float) -> None:
        """Every turn of the reader thread, after its read and before it handles what came: a
        stall of the host since the last turn is counted and logged, once (host_stall.py)."""
        stall = self.checks.reader_turn(now)
        if stall is None:
            return
        limit_ms = self.checks.limits.host_stall_max_s * 1e3
        if stall.ridden:
            self.health.extra["host_stalls"] += 1
            self.log.warning("stall", f"the host stalled {stall.length_s * 1e3:.0f} ms (its reader did not "
                             f"run): ridden through, within host_stall_max_ms {limit_ms:g}; "
                             f"{self.health.extra['host_stalls']} so far")
        else:
            log.warning("the host stalled %.0f ms (its reader did not run), beyond host_stall_max_ms %g: "
                        "the link's checks judge what it made late", stall.length_s * 1e3, limit_ms)

    def watch(self, now: float) -> None:
        """Every turn of the reader thread while the link runs."""
        self.checks.watch(now)

    def status(self, status: Status, now: float) -> None:
        rebooted = self._uptime_ms is not None and status.uptime_ms < self._uptime_ms
        if rebooted or (status.state != FirmwareState.RUNNING and self._state == FirmwareState.RUNNING):
            self.vents += 1  # it stopped applying the host's setpoints on its own
        if rebooted:
            self.health.extra["firmware_reboots"] += 1
            self.restart()
            log.warning("firmware rebooted (uptime %d ms -> %d ms): it vented every valve and "
                        "restarted its counters", self._uptime_ms, status.uptime_ms)
        if status.state == FirmwareState.WATCHDOG_VENTED and self._state != FirmwareState.WATCHDOG_VENTED:
            self.health.extra["firmware_vents"] += 1
            log.warning("firmware watchdog vented every valve: no valid command reached it in time")
        if status.fault_code and status.fault_code != self._fault_code:
            self.health.extra["firmware_faults"] += 1
            log.warning("firmware reports fault %d (%s): it vented every valve", status.fault_code,
                        fault_name(status.fault_code))
        self._fault_code = status.fault_code
        self._uptime_ms = status.uptime_ms
        self._state = status.state
        self.checks.status(status.uptime_ms, now)
