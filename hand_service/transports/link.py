"""The machinery the bus transports share: I/O threads, handshake, reconnect, health.

A reader thread decodes all the board sends, keeps the newest complete sample and watches
the stream (SampleMonitor); a writer thread encodes and sends. The tick only swaps a reference
in latest() and drops the newest command into a one-slot mailbox in send(): a slow or dead
port stalls an I/O thread, never the tick. Losing the board (no frame within
safety.transport_timeout_ms, or an I/O error) closes the link and reconnects with exponential
backoff, shaking hands again before any command goes out."""

from __future__ import annotations

import copy
import logging
import threading
import time
from abc import abstractmethod
from typing import Any

import numpy as np

from hand_service.config.profile import Profile
from hand_service.errors import UserError
from hand_service.transports.base import (
    FirmwareStatus,
    HandshakeError,
    Link,
    LinkProblem,
    SensorSample,
    Transport,
    TransportHealth,
)
from hand_service.transports.checks import READ_TIMEOUT_S, LinkLimits
from hand_service.transports.monitor import SampleMonitor
from hand_service.transports.priority import below_tick
from hand_service.wire.messages import (
    ALL_FINGERS,
    FAULT_VALUE_MODULO,
    FaultKind,
    FaultRequest,
    FirmwareState,
    Message,
    SensorReport,
    Status,
    ValveCommand,
    VersionInfo,
    VersionRequest,
    fault_name,
)

log = logging.getLogger("hand_service.transports")

HANDSHAKE_RETRY_S = 0.1


class LinkTransport(Transport):
    """A Transport over a Link and a codec (CanCodec, SerialCodec)."""

    def __init__(self, profile: Profile, **options: Any) -> None:
        unknown = sorted(set(options) - set(profile.transport))
        if unknown:
            raise UserError(f"unknown option(s) for a {self.kind} transport: {', '.join(unknown)}")
        self.profile = profile
        self.settings = {**profile.transport, **options}
        self.n_fingers = len(profile.fingers)
        self.timeout_s = profile.safety["transport_timeout_ms"] / 1e3
        self.handshake_timeout_s = self.settings["handshake_timeout_ms"] / 1e3
        self._health = TransportHealth()
        self.codec = self._make_codec()
        self._command_range_kpa = self.codec.command_range_kpa()
        self.link = self._make_link()
        self.monitor = SampleMonitor(profile.finger_names, self.settings,
                                     profile.safety["stale_sensor_ticks"] / profile.control.rate_hz,
                                     self._health, LinkLimits.from_profile(profile.safety,
                                                                           profile.control.rate_hz))
        self._lock = threading.Lock()
        self._link_lock = threading.Lock()
        self._wake = threading.Event()
        self._stop = threading.Event()
        self._phase_changed = threading.Condition(self._lock)
        self._threads: list[threading.Thread] = []
        self._connected = False
        self._phase = "closed"  # closed | handshake | running | failed
        self._failure = ""
        self._latest: SensorSample | None = None
        self._status: FirmwareStatus | None = None
        self._firmware_state: Status | None = None
        self._command: ValveCommand | None = None
        self._outbox: list[Message] = []
        self._command_sequence = 0  # unwrapped; the first command is 1
        self._last_rx_s = 0.0
        self._handshake_started_s = 0.0
        self._last_request_s = 0.0
        self._opened_once = False
        self._bad_frames_seen = (0, 0)
        self._backoff_s = self.settings["reconnect_backoff_min_ms"] / 1e3

    # -- what subclasses provide ---------------------------------------------------------

    @abstractmethod
    def _make_codec(self) -> Any: ...

    @abstractmethod
    def _make_link(self) -> Link: ...

    def _record(self, units: list[Any], received: bool) -> None:
        """Raw-traffic logging hook (CAN writes python-can logs)."""

    # -- the Transport contract ------------------------------------------------------------

    def open(self) -> FirmwareStatus:
        if self._threads:
            return self._require_status()
        self._stop.clear()
        self.monitor.begin()
        try:
            self._connect()
        except Exception as exc:
            raise HandshakeError(f"cannot open {self.link.description}: {exc}") from None
        self._threads = [threading.Thread(target=self._read_loop, name=f"{self.kind}-reader", daemon=True),
                         threading.Thread(target=self._write_loop, name=f"{self.kind}-writer", daemon=True)]
        for thread in self._threads:
            thread.start()
        with self._lock:
            self._phase_changed.wait_for(lambda: self._phase in ("running", "failed"),
                                         self.handshake_timeout_s + 0.2)
            phase, failure = self._phase, self._failure
        if phase != "running":
            self.close()
            raise HandshakeError(failure or (
                f"no answer from the firmware on {self.link.description} within "
                f"{self.handshake_timeout_s * 1e3:.0f} ms: is it powered, and on this port?"))
        self._opened_once = True
        log.info("%s: firmware %s, protocol %d", self.link.description,
                 self._require_status().firmware_version, self.profile.protocol_version)
        return self._require_status()

    def close(self) -> None:
        self._stop.set()
        self._wake.set()
        for thread in self._threads:
            thread.join(timeout=2.0)
        self._threads = []
        self._disconnect()
        with self._lock:
            self._phase = "closed"

    def latest(self) -> SensorSample | None:
        with self._lock:
            sample, self._latest = self._latest, None
        return sample

    def send(self, pressure_cmd_kpa: np.ndarray) -> None:
        """Queue setpoints; ValueError (here, in the caller's thread) for one the wire cannot
        carry: a command is never clipped, and never dropped by the writer thread."""
        command = [float(x) for x in pressure_cmd_kpa]
        low, high = self._command_range_kpa
        for kpa in command:
            if not low <= kpa <= high:  # NaN too
                raise ValueError(f"pressure command {kpa:g} kPa: {self.link.description} carries "
                                 f"{low:g}..{high:g} kPa")
        with self._lock:
            self._command_sequence += 1
            self._command = ValveCommand(self._command_sequence, command)
        self.monitor.checks.command_sent(self._command_sequence, time.monotonic())
        self._wake.set()

    @property
    def command_sequence(self) -> int:
        """The sequence of the newest command given to send() (compare SensorSample.command_sequence)."""
        return self._command_sequence

    def status(self) -> FirmwareStatus | None:
        with self._lock:
            return copy.copy(self._status)

    def health(self) -> TransportHealth:
        stats = self.codec.stats
        with self._lock:
            h = copy.copy(self._health)
            h.extra = dict(self._health.extra)
        h.frames_in, h.crc_errors, h.decode_errors = stats.frames, stats.crc_errors, stats.decode_errors
        h.extra.update(incomplete_messages=stats.incomplete, garbage_bytes=stats.garbage_bytes,
                       frame_gaps=stats.frame_gaps, ignored_frames=stats.ignored)
        return h

    def link_problem(self) -> LinkProblem | None:
        return self.monitor.checks.problem

    def link_estimates(self) -> dict[str, float | None]:
        return self.monitor.checks.estimates()

    def inject_fault(self, kind: FaultKind | str, finger_index: int = ALL_FINGERS, duration_ms: int = 0,
                     value: int = 0) -> None:
        """Ask the (mock) firmware's debug port for a fault; see FaultKind. `value` is 16 bits
        on the wire: a negative one (a slow CLOCK_DRIFT) crosses as its two's complement."""
        fault = FaultKind[kind.upper()] if isinstance(kind, str) else kind
        log.info("asking the firmware for fault %s (finger %s, %d ms, value %d)", fault.name.lower(),
                 finger_index, duration_ms, value)
        self._queue(FaultRequest(fault, finger_index, duration_ms, value % FAULT_VALUE_MODULO))

    # -- I/O threads -----------------------------------------------------------------------

    def _queue(self, message: Message) -> None:
        with self._lock:
            self._outbox.append(message)
        self._wake.set()

    def _set_phase(self, phase: str, failure: str = "") -> None:
        with self._lock:
            self._phase, self._failure = phase, failure
            self._phase_changed.notify_all()

    def _connect(self) -> None:
        with self._link_lock:
            self.link.connect()
            self._connected = True
        reset = getattr(self.codec, "reset", None)
        if reset:
            reset()
        self.monitor.restart()
        now = time.monotonic()
        self._last_rx_s = self._handshake_started_s = now
        self._last_request_s = 0.0
        self._set_phase("handshake")

    def _disconnect(self) -> None:
        with self._link_lock:
            if self._connected:
                self._connected = False
                try:
                    self.link.close()
                except Exception as exc:  # closing a port that already vanished
                    log.debug("closing %s: %s", self.link.description, exc)

    def _back_off(self) -> None:
        self._backoff_s = min(2 * self._backoff_s, self.settings["reconnect_backoff_max_ms"] / 1e3)

    def _read_loop(self) -> None:
        below_tick()
        self._backoff_s = self.settings["reconnect_backoff_min_ms"] / 1e3
        while not self._stop.is_set():
            if not self._connected:
                if self._stop.wait(self._backoff_s):
                    return
                try:
                    self._connect()
                except Exception as exc:
                    log.debug("reconnecting to %s: %s", self.link.description, exc)
                    self._back_off()
                    continue
            try:
                units = self.link.read(READ_TIMEOUT_S)
            except Exception as exc:
                self._lose(f"{self.link.description}: read failed ({exc})")
                continue
            now = time.monotonic()
            self.monitor.turn(now)  # a stall of this host since the last turn: not the link's
            if units:
                self._record(units, received=True)
                self._last_rx_s = now
                self._receive(units, now)
                self._log_bad_frames()
            self._watch(now)

    def _receive(self, units: list[Any], now: float) -> None:
        """What arrived, decoded and handled (a transport may route some units elsewhere)."""
        for unit in units:
            for message in self.codec.decode(unit):
                self._handle(message, now)

    def _log_bad_frames(self) -> None:
        stats = self.codec.stats
        bad = (stats.crc_errors, stats.decode_errors)
        if bad != self._bad_frames_seen:
            crc, other = (now - seen for now, seen in zip(bad, self._bad_frames_seen, strict=True))
            self._bad_frames_seen = bad
            self.monitor.log.warning("bad", f"{self.link.description}: {crc} frame(s) failed their CRC, "
                                     f"{other} could not be decoded (last: {stats.errors[-1]})")

    def _watch(self, now: float) -> None:
        """Timeouts and handshake retries."""
        phase = self._phase
        if phase == "running":
            self.monitor.watch(now)
        if phase == "running" and now - self._last_rx_s > self.timeout_s:
            with self._lock:
                self._health.timeouts += 1
            self._lose(f"no frame from the firmware for {(now - self._last_rx_s) * 1e3:.0f} ms "
                       f"(timeout {self.timeout_s * 1e3:.0f} ms): reconnecting")
        elif phase == "handshake":
            if now - self._handshake_started_s > self.handshake_timeout_s and self._opened_once:
                self._lose(f"no handshake from the firmware on {self.link.description} within "
                           f"{self.handshake_timeout_s * 1e3:.0f} ms: retrying", level=logging.DEBUG)
                self._back_off()
            elif now - self._last_request_s > HANDSHAKE_RETRY_S:
                self._last_request_s = now
                self._queue(VersionRequest(self.profile.protocol_version))

    def _lose(self, reason: str, level: int = logging.WARNING) -> None:
        log.log(level, reason)
        self._disconnect()
        if self._phase != "failed":
            self._set_phase("handshake")

    def _write_loop(self) -> None:
        below_tick()
        while not self._stop.is_set():
            self._wake.wait(0.1)
            self._wake.clear()
            self._flush()
        self._flush()  # what was queued as close() began (the shutdown's vent) still goes out

    def _flush(self) -> None:
        with self._lock:
            outbox, self._outbox = self._outbox, []
            if self._phase == "running" and self._command is not None:
                outbox.append(self._command)
            self._command = None
        for message in outbox:
            self._write(message)

    def _encode(self, message: Any) -> list[Any]:
        return self.codec.encode(message)

    def _write(self, message: Message) -> None:
        units = self._encode(message)
        with self._link_lock:
            if not self._connected:
                return
            try:
                self.link.write(units)
            except Exception as exc:  # the reader notices the lost link and reconnects
                log.debug("writing to %s: %s", self.link.description, exc)
                return
        self._record(units, received=False)
        with self._lock:
            self._health.frames_out += len(units)

    def _handle(self, message: Message, now: float) -> None:
        if isinstance(message, SensorReport):
            if self._phase == "running":
                sample = self.monitor.sample(message, now, self._command_sequence)
                if sample is not None:
                    with self._lock:
                        if self._latest is not None:  # not taken yet: replaced, not lost
                            sample.lost_in_a_row = max(sample.lost_in_a_row, self._latest.lost_in_a_row)
                        self._latest = sample
        elif isinstance(message, Status):
            self.monitor.status(message, now)
            self._firmware_state = message
            with self._lock:
                self._apply_state(self._status)
        elif isinstance(message, VersionInfo):
            self._handshake(message)

    def _apply_state(self, status: FirmwareStatus | None) -> None:
        """The newest Status into what status() reports: the board's own fault, apart from
        the fault injected on its debug port."""
        state = self._firmware_state
        if status is not None and state is not None:
            status.state = state.state.name.lower()
            status.vented = state.state != FirmwareState.RUNNING
            status.vents = self.monitor.vents
            status.fault_code = int(state.fault_code)
            status.fault_text = fault_name(int(state.fault_code))
            status.injected_fault = int(state.fault_active)

    def _handshake(self, info: VersionInfo) -> None:
        wanted = self.profile.protocol_version
        problem = ""
        if info.protocol_version != wanted:
            problem = (f"{self.link.description}: the firmware ({info.firmware_text}) speaks protocol "
                       f"{info.protocol_version}, but profile '{self.profile.name}' needs protocol "
                       f"{wanted}: flash a firmware for protocol {wanted} or pick a profile for "
                       f"protocol {info.protocol_version}")
        elif info.finger_count != self.n_fingers:
            problem = (f"{self.link.description}: the firmware drives {info.finger_count} fingers, but "
                       f"profile '{self.profile.name}' has {self.n_fingers}")
        if problem:
            if self._phase == "running":  # a board that changes its protocol mid-run
                self.monitor.checks.protocol_changed(problem)
            if self._phase != "failed":
                log.error("%s", problem)
            self._set_phase("failed", problem)
            return
        with self._lock:
            self._status = FirmwareStatus(info.protocol_version, info.firmware_text)
            self._apply_state(self._status)
        if self._phase == "handshake":
            if self._opened_once:
                with self._lock:
                    self._health.reconnects += 1
                log.warning("%s: reconnected to firmware %s", self.link.description, info.firmware_text)
            self._backoff_s = self.settings["reconnect_backoff_min_ms"] / 1e3
            self._set_phase("running")

    def _require_status(self) -> FirmwareStatus:
        status = self.status()
        assert status is not None
        return status
