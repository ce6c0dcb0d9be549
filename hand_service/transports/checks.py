"""The bus transport's own checks of the link, run in its reader thread: each names a
LinkProblem the supervisor faults on (Transport.link_problem()), so the tick only reads
one reference.

    sample_late       a sample older than safety.sample_age_max_ms on the board's clock,
                      or none newer for that long (board_clock.SampleAge)
    sample_loss       more than safety.sample_loss_max_percent of the board's samples lost
                      (dropped, or failed their CRC) over the last LOSS_WINDOW_S
    sequence_stuck    safety.stale_sensor_ticks samples in a row with the same sequence
    latency           the command -> sensor round trip, on the host's clock alone, over
                      safety.latency_max_ms for a whole round_trip.WINDOW_S (round_trip.RoundTrip):
                      a slow link, in either direction, apart from the board's clock
    clock_drift       the board's clock runs faster or slower than the host's by more than
                      safety.clock_drift_max_ppm (board_clock.ClockDrift)
    bus_error         CAN: bus-off or error-passive at once; more than
                      safety.bus_error_frames_max error frames in any second
    protocol_changed  the board announced another protocol version mid-run

The first problem stays until the link is opened again (begin()). A stall of the host
itself, shorter than safety.host_stall_max_ms, is not the link's: the samples it made
late or lost are excused (host_stall.HostStalls).
"""

from __future__ import annotations

import logging
from collections import deque
from dataclasses import dataclass
from typing import Any

import can

from hand_service.config.safety import SAFETY_SECTION
from hand_service.transports.base import LinkProblem
from hand_service.transports.board_clock import ClockDrift, SampleAge
from hand_service.transports.host_stall import READ_TIMEOUT_S, HostStalls, Stall
from hand_service.transports.round_trip import RoundTrip
from hand_service.wire import can_errors

log = logging.getLogger("hand_service.transports")

LOSS_WINDOW_S = 0.5
DEFAULT_RATE_HZ = 100.0
BUS_ERROR_WINDOW_S = 1.0


@dataclass(frozen=True)
class LinkLimits:
    """The profile's safety limits the link checks enforce."""

    period_s: float
    stale_sensor_ticks: int
    sample_age_max_s: float
    sample_loss_max_percent: float
    clock_drift_max_ppm: float
    bus_error_frames_max: int
    latency_max_s: float
    host_stall_max_s: float

    @staticmethod
    def from_profile(safety: dict[str, Any], rate_hz: float) -> LinkLimits:
        return LinkLimits(1.0 / rate_hz, int(safety["stale_sensor_ticks"]),
                          safety["sample_age_max_ms"] / 1e3, float(safety["sample_loss_max_percent"]),
                          float(safety["clock_drift_max_ppm"]), int(safety["bus_error_frames_max"]),
                          safety["latency_max_ms"] / 1e3, safety["host_stall_max_ms"] / 1e3)

    @staticmethod
    def defaults(rate_hz: float = DEFAULT_RATE_HZ) -> LinkLimits:
        """The profile schema's default limits (for a monitor tested on its own)."""
        return LinkLimits.from_profile({k.name: k.default for k in SAFETY_SECTION.keys}, rate_hz)


class LinkChecks:
    def __init__(self, limits: LinkLimits) -> None:
        self.limits = limits
        self.problem: LinkProblem | None = None
        self.age = SampleAge(limits.period_s)
        self.drift = ClockDrift()
        self.round_trip = RoundTrip()
        self.stalls = HostStalls(READ_TIMEOUT_S, limits.host_stall_max_s, limits.period_s)
        self.loss_window = max(1, round(LOSS_WINDOW_S / limits.period_s))
        self._losses: deque[tuple[int, int]] = deque()  # (sample index, samples lost before it)
        self._lost = 0
        self._first_index: int | None = None
        self._same_sequence = 0
        self._error_times: deque[float] = deque()
        self.worst_age_s = 0.0  # the oldest sample seen since begin(), for the log and the tests
        self.drift_ppm: float | None = None  # the newest estimate
        self.round_trip_s: float | None = None  # the newest estimate (round_trip.RoundTrip)
        self.worst_round_trip_s = 0.0  # its largest since begin()

    def begin(self) -> None:
        """The host opens the link: no problem yet."""
        self.problem = None
        self.worst_age_s = 0.0
        self.worst_round_trip_s = 0.0
        self._error_times.clear()
        self.restart()

    def restart(self) -> None:
        """The board's counts start over (a reconnect, a reboot)."""
        self.age.reset()
        self.drift.reset()
        self.drift_ppm = None
        self.round_trip.reset()
        self.round_trip_s = None
        self.stalls.reset()
        self._losses.clear()
        self._lost = 0
        self._first_index = None
        self._same_sequence = 0

    def estimates(self) -> dict[str, float | None]:
        """What `status` shows of the link (Transport.link_estimates)."""
        trip_s, stalls, limits = self.round_trip_s, self.stalls, self.limits
        return {"host_stalls": stalls.count, "host_stall_worst_ms": round(stalls.worst_s * 1e3, 1),
                "host_stall_max_ms": round(limits.host_stall_max_s * 1e3, 1),
                "round_trip_ms": None if trip_s is None else round(trip_s * 1e3, 2),
                "round_trip_max_ms": round(self.worst_round_trip_s * 1e3, 2),
                "latency_max_ms": round(limits.latency_max_s * 1e3, 2),
                "clock_drift_ppm": None if self.drift_ppm is None else round(self.drift_ppm)}

    def found(self, kind: str, detail: str) -> None:
        if self.problem is None:
            self.problem = LinkProblem(kind, detail)
            log.error("link: %s: %s", kind, detail)

    # -- samples ------------------------------------------------------------------------

    def command_sent(self, sequence: int, host_s: float) -> None:
        """The host counted command `sequence` (unwrapped) to go out at host_s."""
        self.round_trip.sent(sequence, host_s)

    def reader_turn(self, host_s: float) -> Stall | None:
        """The reader thread turns at host_s (before it handles what it read): the host's stall
        since its last turn."""
        return self.stalls.turn(host_s)

    def excused(self, host_s: float) -> bool:
        """A host stall ridden through excuses what arrives at host_s."""
        return self.stalls.excused_s(host_s) > 0.0

    def sample(self, index: int, lost: int, host_s: float, echoed: int = -1) -> None:
        """The board's index-th sample (unwrapped) arrived at host_s; `lost` never did before it;
        it echoes command `echoed` (unwrapped; -1: none yet)."""
        self._same_sequence = 0
        age_s = self.age.sample(index, host_s)
        self.worst_age_s = max(self.worst_age_s, age_s)
        excused_s = self.stalls.excused_s(host_s)
        if excused_s:  # the host's own stall: its part of the age, and its losses, are not the link's
            age_s -= excused_s
            self.stalls.lost += lost
            lost = 0
        if age_s > self.limits.sample_age_max_s:
            self.found("sample_late", f"a sample arrived {age_s * 1e3:.0f} ms after the board took it "
                       f"(sample_age_max_ms {self.limits.sample_age_max_s * 1e3:g})")
        if echoed > 0:
            self._round_trip(self.round_trip.echoed(echoed, host_s))
        self._count_loss(index, lost)

    def _round_trip(self, trip_s: float | None) -> None:
        self.round_trip_s = trip_s
        if trip_s is None:
            return
        self.worst_round_trip_s = max(self.worst_round_trip_s, trip_s)
        if trip_s > self.limits.latency_max_s:
            self.found("latency", f"no command came back in a sample within {trip_s * 1e3:.0f} ms "
                       f"over the last {self.round_trip.window_s * 1e3:.0f} ms, on the host's clock "
                       f"(latency_max_ms {self.limits.latency_max_s * 1e3:g})")

    def _count_loss(self, index: int, lost: int) -> None:
        if self._first_index is None:
            self._first_index = index
        losses = self._losses
        losses.append((index, lost))
        self._lost += lost
        while losses[0][0] <= index - self.loss_window:
            self._lost -= losses.popleft()[1]
        if index - self._first_index < self.loss_window:
            return  # not a whole window yet
        percent = 100.0 * self._lost / self.loss_window
        if percent > self.limits.sample_loss_max_percent:
            self.found("sample_loss", f"{self._lost} of the board's last {self.loss_window} samples "
                       f"never arrived ({percent:.0f} %, sample_loss_max_percent "
                       f"{self.limits.sample_loss_max_percent:g})")

    def same_sequence(self, sequence: int) -> None:
        """A sample came with the sequence of the one before it."""
        self._same_sequence += 1
        if self._same_sequence >= self.limits.stale_sensor_ticks:
            self.found("sequence_stuck", f"{self._same_sequence} samples in a row carried sequence "
                       f"{sequence} (stale_sensor_ticks {self.limits.stale_sensor_ticks})")

    def watch(self, host_s: float) -> None:
        """Every turn of the reader: the newest sample grows old while nothing arrives."""
        age_s = self.age.age_now(host_s)
        if age_s is not None:
            age_s -= self.stalls.excused_s(host_s)
        if age_s is not None and age_s > self.limits.sample_age_max_s:
            self.found("sample_late", f"no sample newer than {age_s * 1e3:.0f} ms on the board's "
                       f"clock (sample_age_max_ms {self.limits.sample_age_max_s * 1e3:g})")

    # -- the board's clock, its protocol, the bus ----------------------------------------

    def status(self, uptime_ms: int, host_s: float) -> None:
        drift_ppm = self.drift.status(uptime_ms / 1e3, host_s)
        self.drift_ppm = drift_ppm
        if drift_ppm is not None and abs(drift_ppm) > self.limits.clock_drift_max_ppm:
            pace = "fast" if drift_ppm > 0 else "slow"
            self.found("clock_drift", f"the board's clock runs {abs(drift_ppm):.0f} ppm {pace} against "
                       f"the host's (clock_drift_max_ppm {self.limits.clock_drift_max_ppm:g})")

    def protocol_changed(self, detail: str) -> None:
        self.found("protocol_changed", detail)

    def bus_error(self, frame: can.Message, host_s: float) -> None:
        """A CAN error frame from the host's driver."""
        if can_errors.is_bus_off(frame) or can_errors.is_error_passive(frame):
            state = "bus-off" if can_errors.is_bus_off(frame) else "error-passive"
            self.found("bus_error", f"the CAN controller went {state} ({can_errors.describe(frame)})")
            return
        times = self._error_times
        times.append(host_s)
        while times[0] < host_s - BUS_ERROR_WINDOW_S:
            times.popleft()
        if len(times) > self.limits.bus_error_frames_max:
            self.found("bus_error", f"{len(times)} CAN error frames within {BUS_ERROR_WINDOW_S:g} s "
                       f"({can_errors.describe(frame)}; bus_error_frames_max "
                       f"{self.limits.bus_error_frames_max})")

    def bus_state(self, state: can.BusState) -> None:
        """The bus state the interface keeps (python-can BusState), where it keeps one."""
        if state is not can.BusState.ACTIVE:
            self.found("bus_error", f"the CAN bus state is {state.name.lower()}"
                       f"{' (bus-off)' if state is can.BusState.ERROR else ''}")
