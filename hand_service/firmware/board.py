"""The valve-board firmware (board/core, compiled into hand_service.firmware._board) run in
this process against its simulated hand, on any of the firmware's ports (ports.py): a
python-can bus (the virtual bus in a thread), a pty that speaks serial-v1, or an SLCAN
adapter on a pty.

This module only moves bytes and frames between the port and the C board's queues and
gives the C board its clock; every decision (protocol, sampling, watchdog, faults) is the
C core's, the same code the host build (board/host) and the MCU images run.
"""

from __future__ import annotations

import logging
import threading
import time
from dataclasses import dataclass
from typing import Any

import can
import numpy as np

from hand_service.config.profile import Profile
from hand_service.firmware._board import ffi, lib
from hand_service.firmware.ports import CanBusPort, FirmwarePort
from hand_service.wire.can_errors import bus_error_frame, bus_off_frame

log = logging.getLogger("hand_service.firmware")

FIRMWARE_VERSION = (1, 0, 0)
MAX_WAIT_S = 0.01  # wake at least this often (a drifting board clock, a fault that ends)
SERIAL_CHUNK_BYTES = 4096
STATES = ("booting", "idle", "running", "watchdog_vented", "fault")
# what the C board breaks on purpose (board/core/inject.h, enum inject_broken); board-check's tests
BROKEN = {"no-watchdog": 1, "wrong-crc": 2, "stuck-sequence": 3, "echo-version": 4, "silent-reboot": 5,
          "quiet-idle": 6, "counts-rubbish": 7, "zero-vents": 8, "valves-dead": 9, "valve-stuck": 10,
          "pressure-nan": 11, "pressure-x2": 12, "flex-stuck": 13, "flex-x2": 14}
_LOCK = threading.Lock()  # the C HAL runs one instance at a time (board/inprocess/inprocess.h)


@dataclass
class BoardView:
    """The truth behind the wire, for tests: what the board applies, how the fingers stand."""

    state: int
    fault_code: int
    command_kpa: np.ndarray
    angle_deg: np.ndarray


class BoardFirmware:
    """The C firmware on `port`; `run` until `stop_event` (or `seconds`)."""

    def __init__(self, profile: Profile, port: FirmwarePort, protocol_version: int | None = None,
                 firmware_version: tuple[int, int, int] = FIRMWARE_VERSION, seed: int | None = None,
                 broken: str | None = None) -> None:
        self.profile = profile
        self.port = port
        self.n = len(profile.fingers)
        self.can = profile.transport["kind"] == "can"
        self.protocol_version = profile.protocol_version if protocol_version is None else protocol_version
        self.firmware_version = firmware_version
        self.stop_event = threading.Event()
        self.vent_times_s: list[float] = []  # monotonic time of every watchdog vent
        config = ffi.new("struct inprocess_config *")
        config.can = self.can
        config.n_fingers = self.n
        config.protocol_version = self.protocol_version
        config.firmware_version = list(firmware_version)
        config.sample_period_us = round(1e6 / profile.control.rate_hz)
        config.watchdog_us = round(profile.safety["firmware_watchdog_ms"] * 1e3)
        config.seed = profile.simulation["seed"] if seed is None else seed
        config.can_error_frames = port.carries_error_frames
        config.broken = BROKEN[broken] if broken is not None else 0
        self._config = config
        self._memory = ffi.new("char[]", lib.inprocess_size())
        self._board = ffi.cast("struct inprocess *", self._memory)
        self._frame = ffi.new("struct inprocess_frame *")
        self._view = ffi.new("struct inprocess_view *")
        self._out = ffi.new("uint8_t[]", SERIAL_CHUNK_BYTES)
        self._t0_s = time.monotonic()
        self._vents_seen = 0
        self._state = -1
        self._start()

    def _now_us(self) -> int:
        return int((time.monotonic() - self._t0_s) * 1e6)

    def _start(self) -> None:
        with _LOCK:
            if lib.inprocess_init(self._board, self._config, self._now_us()) != 0:
                raise ValueError(f"{self.profile.path}: the firmware refuses this hand "
                                 f"({self.n} fingers, {self.profile.control.rate_hz:g} Hz)")

    # -- the loop ----------------------------------------------------------------------------

    def run(self, seconds: float | None = None) -> None:
        end = None if seconds is None else time.monotonic() + seconds
        log.info("booted: firmware %s, protocol %d, %d fingers, watchdog %.0f ms",
                 ".".join(map(str, self.firmware_version)), self.protocol_version, self.n,
                 self._config.watchdog_us / 1e3)
        while not self.stop_event.is_set() and (end is None or time.monotonic() < end):
            wait_s = (lib.inprocess_next_event_us(self._board) - self._now_us()) / 1e6
            units = self.port.read(min(MAX_WAIT_S, max(0.0, wait_s)))
            with _LOCK:
                self._receive(units)
                lib.inprocess_run(self._board, self._now_us())
                out = self._sent()
                lib.inprocess_view(self._board, self._view)
            if out:
                self.port.write(out)
            self._log_changes()

    def _receive(self, units: list[Any]) -> None:
        for unit in units:
            if isinstance(unit, can.Message):
                if not (unit.is_error_frame or unit.is_remote_frame or unit.is_extended_id):
                    lib.inprocess_can_push(self._board, unit.arbitration_id, bytes(unit.data), unit.dlc)
                continue
            data = bytes(unit)
            while data:  # a burst longer than the UART's buffer: the board takes it in turns
                taken = lib.inprocess_serial_push(self._board, data, len(data))
                data = data[taken:]
                if data:
                    lib.inprocess_run(self._board, self._now_us())

    def _sent(self) -> list[Any]:
        if not self.can:
            got = lib.inprocess_serial_pop(self._board, self._out, SERIAL_CHUNK_BYTES)
            chunks = []
            while got:
                chunks.append(bytes(ffi.buffer(self._out, got)))
                got = lib.inprocess_serial_pop(self._board, self._out, SERIAL_CHUNK_BYTES)
            return chunks
        frames: list[can.Message] = []
        frame = self._frame
        while lib.inprocess_can_pop(self._board, frame):
            if frame.kind == lib.INPROCESS_BUS_ERROR:
                frames.append(bus_error_frame())
            elif frame.kind == lib.INPROCESS_BUS_OFF:
                frames.append(bus_off_frame())
            else:
                frames.append(can.Message(arbitration_id=frame.id, is_extended_id=False,
                                          data=bytes(frame.data[0:frame.len])))
        return frames

    def _log_changes(self) -> None:
        view = self._view
        if view.vent_count != self._vents_seen:
            self._vents_seen = view.vent_count
            vent_s = self._t0_s + view.vent_at_us / 1e6
            self.vent_times_s.append(vent_s)
            log.warning("watchdog: no valid command for %.0f ms: vented every valve (t_monotonic_s=%.6f)",
                        self._config.watchdog_us / 1e3, vent_s)
        if view.state != self._state:
            self._state = view.state
            name = STATES[view.state] if view.state < len(STATES) else str(view.state)
            log.info("state: %s, fault_code %d", name, view.fault_code)

    def view(self) -> BoardView:
        with _LOCK:
            lib.inprocess_view(self._board, self._view)
            return BoardView(self._view.state, self._view.fault_code,
                             np.array(ffi.unpack(self._view.command_kpa, self.n), dtype=float),
                             np.array(ffi.unpack(self._view.angle_deg, self.n), dtype=float))


class BoardThread:
    """The C firmware in a thread of this process (on python-can's virtual bus)."""

    def __init__(self, firmware: BoardFirmware) -> None:
        self.firmware = firmware
        self.thread = threading.Thread(target=firmware.run, name="board-firmware", daemon=True)

    def start(self) -> BoardThread:
        self.thread.start()
        return self

    def stop(self) -> None:
        self.firmware.stop_event.set()
        self.thread.join(timeout=5.0)
        self.firmware.port.close()

    def __enter__(self) -> BoardThread:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.stop()


def run_in_thread(profile: Profile, channel: str | None = None, **options: Any) -> BoardThread:
    """Start the firmware on the profile's virtual CAN channel (or `channel`) in a thread."""
    settings = profile.transport
    if settings["kind"] != "can" or settings["interface"] != "virtual":
        raise ValueError("run_in_thread needs a profile on python-can's virtual bus")
    bus = can.Bus(interface="virtual", channel=channel or settings["channel"])
    return BoardThread(BoardFirmware(profile, CanBusPort(bus), **options)).start()
