"""The `can` transport: a valve board on CAN through python-can; frames from the profile's DBC.

Any python-can interface works (SocketCAN, PCAN, Kvaser, ...). Two are tested here:
`virtual` (in-process; the mock firmware runs in a thread) and `slcan` on a pseudo-
terminal (the mock firmware plays the adapter in another process). With `raw_log`,
every frame in and out is written with can.Logger (.asc, .blf, ...) for lab tools.
Error frames from the driver and the interface's bus state go to the link checks
(checks.py): bus-off and error-passive fault at once, a burst of error frames too.

On a DBC with can-v1's own layout the codec is the C one (wire/can_c_codec.py), and the
supervisor's tick runs in C around the bus I/O (can_tick.py, bus_tick): the reader thread
also hands the samples' frames to the tick's batch, which the tick decodes for its inputs.
"""

from __future__ import annotations

import logging
import threading
import time
from pathlib import Path
from typing import Any

import can

from hand_service.errors import UserError
from hand_service.transports.base import FirmwareStatus
from hand_service.transports.can_tick import CanTick, CanTickState, CommandFrames
from hand_service.transports.checks import LinkChecks
from hand_service.transports.in_c import BusTickInC
from hand_service.transports.link import Link, LinkTransport
from hand_service.wire.can_c_codec import CCanCodec, builtin_layout
from hand_service.wire.can_codec import CanCodec
from hand_service.wire.messages import Message, Status

log = logging.getLogger("hand_service.transports")

MAX_FRAMES_PER_READ = 256
MAX_LOG_CHANNEL = 0xFFFF  # BLF stores the channel number (+1) in 16 bits


def bus_arguments(settings: dict[str, Any]) -> dict[str, Any]:
    """can.Bus keyword arguments for a profile's transport settings."""
    kwargs: dict[str, Any] = {"interface": settings["interface"], "channel": settings["channel"],
                              "bitrate": settings["bitrate_bps"]}
    if settings["interface"] == "slcan":
        kwargs.update(tty_baudrate=settings["tty_baudrate_bps"], sleep_after_open=0)
    return kwargs


class CanLink(Link):
    def __init__(self, settings: dict[str, Any], codec: CanCodec) -> None:
        self.kwargs = bus_arguments(settings)
        self.codec = codec
        self.description = f"CAN {settings['interface']}:{settings['channel']}"
        self.bus: can.BusABC | None = None
        self.checks: LinkChecks | None = None  # told of error frames and the bus state

    def connect(self) -> None:
        self.bus = can.Bus(**self.kwargs)

    def close(self) -> None:
        if self.bus is not None:
            bus, self.bus = self.bus, None
            bus.shutdown()

    def read(self, timeout_s: float) -> list[can.Message]:
        assert self.bus is not None
        frames: list[can.Message] = []
        wait = timeout_s
        while len(frames) < MAX_FRAMES_PER_READ:
            try:
                frame = self.bus.recv(wait)
            except (ValueError, IndexError, can.CanOperationError) as exc:
                if not self._garbled(exc):
                    raise
                continue
            if frame is None:
                break
            if frame.is_error_frame and self.checks is not None:
                self.checks.bus_error(frame, time.monotonic())
            frames.append(frame)  # an error frame too, for the raw log (the codec ignores it)
            wait = 0.0
        self._check_state()
        return frames

    def _check_state(self) -> None:
        """The bus state, where the interface keeps one (python-can's default: active)."""
        if self.checks is None or self.bus is None:
            return
        try:
            state = self.bus.state
        except (can.CanError, NotImplementedError):
            return
        if state is not can.BusState.ACTIVE:
            self.checks.bus_state(state)

    def _garbled(self, exc: Exception) -> bool:
        """A garbled SLCAN line (count it, read on), or a real failure of the port (False).

        python-can's slcan parser raises ValueError or IndexError on a malformed line. A byte
        that is not UTF-8 comes as CanOperationError from a UnicodeDecodeError, and python-can
        (4.6) keeps the bad line in its buffer, so every later line would fail too: the line
        is dropped from that buffer (flush() where there is none, losing what is queued).
        """
        cause = exc.__cause__ if isinstance(exc, can.CanOperationError) else exc
        if not isinstance(cause, (ValueError, IndexError)):  # UnicodeDecodeError is a ValueError
            return False
        self.codec.stats.decode_errors += 1
        self.codec.stats.note(f"unreadable line from the adapter: {cause}")
        if isinstance(cause, UnicodeDecodeError) and self.bus is not None:
            line = getattr(self.bus, "_buffer", None)
            if isinstance(line, bytearray):
                line.clear()
            else:
                self.bus.flush()
        return True

    def write(self, units: list[can.Message]) -> None:
        assert self.bus is not None
        for frame in units:
            self.bus.send(frame, timeout=0.5)


class CanTransport(LinkTransport, BusTickInC):
    kind = "can"

    def __init__(self, profile: Any, tick_in_c: bool | None = None, **options: Any) -> None:
        """tick_in_c: the codec and the supervisor's tick in C (default: when the DBC has
        can-v1's layout; True on another DBC is a UserError); False: both in Python."""
        self._status_version = 0  # bumped at every change of the status (_apply_state)
        self._status_copied = -1
        self._status_copy: FirmwareStatus | None = None
        dbc = options.get("dbc", profile.transport["dbc"])
        builtin = builtin_layout(dbc)
        if tick_in_c and not builtin:
            raise UserError(f"{dbc}: the tick in C speaks firmware_profiles/can-v1.dbc's layout only")
        self.tick_in_c = builtin if tick_in_c is None else tick_in_c
        super().__init__(profile, **options)
        self.link.checks = self.monitor.checks  # type: ignore[attr-defined]
        self._raw_log: can.Listener | None = None
        self._raw_lock = threading.Lock()
        self.tick_state = CanTickState(self.codec) if self.tick_in_c else None
        self._tick_bound = False  # a supervisor took bus_tick(): its samples go to the batch
        self._sensor_id = self.codec.db.get_message_by_name("SensorFinger").frame_id

    def _make_codec(self) -> CanCodec:
        if self.tick_in_c:
            return CCanCodec(self.settings["dbc"], self.n_fingers)
        return CanCodec(self.settings["dbc"], self.n_fingers)

    # -- the tick in C (can_tick.py) --------------------------------------------------------

    def bus_tick(self, tick: Any) -> CanTick | None:
        if self.tick_state is None:
            return None
        self._tick_bound = True
        return CanTick(self.tick_state, tick.c, self)

    def next_command_sequence(self) -> int:
        """The sequence of the command the tick is about to encode (unwrapped; the first is 1).
        No lock: the supervisor's thread alone counts commands (here and in send())."""
        self._command_sequence += 1
        self.monitor.checks.command_sent(self._command_sequence, time.monotonic())
        return self._command_sequence

    def wake_writer(self) -> None:
        """After the tick: woken in it, the writer would take the interpreter from the tick
        for the whole of its send."""
        self._wake.set()

    def _flush(self) -> None:
        """The tick's frames or the command given to send(), whichever is newer (a vent after
        the last tick, at shutdown, goes out last and alone), then what else is queued."""
        frames = None
        if self.tick_state is not None and self.tick_state.slot:
            try:
                frames = self.tick_state.slot.popleft()
            except IndexError:
                frames = None
        if frames is not None:
            with self._lock:
                command = self._command
                if command is not None and command.sequence > frames.sequence:
                    frames = None
                else:
                    self._command = None
        super()._flush()
        if frames is not None and self._phase == "running":
            self._write(frames)  # type: ignore[arg-type]

    def _apply_state(self, status: FirmwareStatus | None) -> None:
        super()._apply_state(status)
        self._status_version += 1  # under the lock, as every change of the status

    def status(self) -> FirmwareStatus | None:
        """As LinkTransport's, but the copy is made once per change, not per call: every tick
        asks, and a copy under the lock the reader thread takes costs the tick tens of us.
        The copy returned is shared: read it, never change it."""
        version = self._status_version
        if version != self._status_copied:
            self._status_copy, self._status_copied = super().status(), version
        return self._status_copy

    def _encode(self, message: Any) -> list[Any]:
        if isinstance(message, CommandFrames):
            return message.frames()
        return self.codec.encode(message)

    def _receive(self, units: list[Any], now: float) -> None:
        state = self.tick_state
        if state is None or not self._tick_bound or self._phase != "running":
            super()._receive(units, now)
            return
        for unit in units:  # a sample's frames to the tick's batch too: the tick decodes them again
            if unit.arbitration_id == self._sensor_id and not (unit.is_error_frame or unit.is_remote_frame):
                state.add(unit, now)
            for message in self.codec.decode(unit):
                self._handle(message, now)

    def _handle(self, message: Message, now: float) -> None:
        reboots = self._health.extra.get("firmware_reboots", 0)
        super()._handle(message, now)
        if (isinstance(message, Status) and self.tick_state is not None
                and self._health.extra.get("firmware_reboots", 0) != reboots):
            self.tick_state.forget_last_sample()  # the stream starts over

    def _connect(self) -> None:
        super()._connect()
        if self.tick_state is not None:
            self.tick_state.reset()

    def health(self) -> Any:
        h = super().health()
        if self.tick_state is not None:  # its frames are counted by the codec, which saw them too
            h.extra["tick_batch_overflows"] = self.tick_state.dropped
            h.extra["tick_batch_busy"] = self.tick_state.busy_ticks
        return h

    def _make_link(self) -> Link:
        return CanLink(self.settings, self.codec)

    def open(self) -> FirmwareStatus:
        if self.settings["raw_log"] and self._raw_log is None:
            self._raw_log = can.Logger(self.settings["raw_log"])
            log.info("writing raw CAN traffic to %s", Path(self.settings["raw_log"]).resolve())
        return super().open()

    def close(self) -> None:
        super().close()
        with self._raw_lock:
            raw_log, self._raw_log = self._raw_log, None
        if raw_log is not None:
            raw_log.stop()

    def _record(self, units: list[Any], received: bool) -> None:
        with self._raw_lock:
            if self._raw_log is None:
                return
            try:
                for frame in units:
                    frame.is_rx = received
                    number = can.util.channel2int(frame.channel)
                    if number is not None and not 0 <= number < MAX_LOG_CHANNEL:
                        frame.channel = None  # a name ending in a big number: the log's own channel
                    self._raw_log.on_message_received(frame)
            except Exception as exc:  # the raw log must never stop the link's I/O threads
                raw_log, self._raw_log = self._raw_log, None
                log.error("raw CAN log %s failed (%s: %s): raw logging stopped",
                          self.settings["raw_log"], type(exc).__name__, exc)
                try:
                    raw_log.stop()
                except Exception as stop_exc:
                    log.debug("closing the raw CAN log: %s", stop_exc)
