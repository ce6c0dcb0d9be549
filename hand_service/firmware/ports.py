"""The firmware's side of the wire: a python-can bus, or a pseudo-terminal it owns.

On a pty the board plays the device: it holds the master end, the host opens the slave
(a path, like a USB serial port). `SlcanAdapterPort` plays an SLCAN (Lawicel) USB-CAN
adapter on that pty, so the host's python-can `slcan` interface talks to it unchanged.
Writes never block: when nobody reads, bytes are dropped, as a UART drops them.
"""

from __future__ import annotations

import errno
import os
import select
import stat
import termios
import tty
from abc import ABC, abstractmethod
from pathlib import Path
from typing import Any

import can


class FirmwarePort(ABC):
    description = ""
    dropped_bytes = 0
    carries_error_frames = False  # a CAN driver that hands error frames to the host

    @abstractmethod
    def read(self, timeout_s: float) -> list[Any]: ...

    @abstractmethod
    def write(self, units: list[Any]) -> None: ...

    @abstractmethod
    def close(self) -> None: ...


class CanBusPort(FirmwarePort):
    """Any python-can bus (the virtual bus in a thread, or a real interface)."""

    carries_error_frames = True

    def __init__(self, bus: can.BusABC) -> None:
        self.bus = bus
        self.description = f"CAN {bus.channel_info}"

    def read(self, timeout_s: float) -> list[can.Message]:
        frames = []
        frame = self.bus.recv(timeout_s)
        while frame is not None and len(frames) < 256:
            frames.append(frame)
            frame = self.bus.recv(0.0)
        return frames

    def write(self, units: list[can.Message]) -> None:
        for frame in units:
            self.bus.send(frame)

    def close(self) -> None:
        self.bus.shutdown()


class PtyPort(FirmwarePort):
    """A byte stream on a pty this process creates (the host opens `path`), or on an existing tty."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self._slave: int | None = None
        self._link: Path | None = None
        if self.path.exists() and stat.S_ISCHR(self.path.stat().st_mode) and not self.path.is_symlink():
            self.fd = os.open(self.path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
            try:
                tty.setraw(self.fd)
            except termios.error:
                os.close(self.fd)
                raise OSError(errno.ENOTTY, "a device, but not a terminal") from None
            self.device = str(self.path)
        else:
            if self.path.exists() and not self.path.is_symlink():
                raise FileExistsError(errno.EEXIST, "exists and is not a terminal")
            self.fd, self._slave = os.openpty()
            try:
                tty.setraw(self._slave)  # no echo, no line editing, before the host opens it
                os.set_blocking(self.fd, False)
                self.device = os.ttyname(self._slave)
                if self.path.is_symlink():
                    self.path.unlink()  # left by an earlier run
                self.path.symlink_to(self.device)
            except OSError:
                os.close(self.fd)
                os.close(self._slave)
                raise
            self._link = self.path
        self.description = f"{self.path} ({self.device})"

    def read_bytes(self, timeout_s: float) -> bytes:
        ready, _, _ = select.select([self.fd], [], [], max(0.0, timeout_s))
        if not ready:
            return b""
        try:
            return os.read(self.fd, 65536)
        except BlockingIOError:
            return b""
        except OSError as exc:
            if exc.errno == errno.EIO:  # no one holds the other end
                return b""
            raise

    def read(self, timeout_s: float) -> list[bytes]:
        data = self.read_bytes(timeout_s)
        return [data] if data else []

    def write_bytes(self, data: bytes) -> None:
        try:
            written = os.write(self.fd, data)
        except (BlockingIOError, OSError):
            written = 0
        self.dropped_bytes += len(data) - written

    def write(self, units: list[bytes]) -> None:
        self.write_bytes(b"".join(units))

    def close(self) -> None:
        for fd in (self.fd, self._slave):
            if fd is not None:
                os.close(fd)
        if self._link is not None and self._link.is_symlink():
            self._link.unlink()


class SlcanAdapterPort(FirmwarePort):
    """An SLCAN adapter on a pty: ASCII lines to the host, CAN frames to the firmware."""

    OK, ERROR = b"\r", b"\a"

    def __init__(self, pty: PtyPort) -> None:
        self.pty = pty
        self.description = f"SLCAN on {pty.description}"
        self.is_open = False  # the host opens the channel with 'O' and closes it with 'C'
        self.bad_lines = 0
        self._buffer = b""

    @property
    def path(self) -> Path:
        return self.pty.path

    @property
    def dropped_bytes(self) -> int:  # type: ignore[override]
        return self.pty.dropped_bytes

    def read(self, timeout_s: float) -> list[can.Message]:
        self._buffer += self.pty.read_bytes(timeout_s)
        *lines, self._buffer = self._buffer.split(b"\r")
        frames = []
        for line in lines:
            frame = self._command(line.decode("ascii", "replace"))
            if frame is not None:
                frames.append(frame)
        return frames

    def _command(self, line: str) -> can.Message | None:
        code = line[:1]
        try:
            if code in ("t", "T"):
                id_digits = 3 if code == "t" else 8
                dlc = int(line[1 + id_digits])
                data = bytes.fromhex(line[2 + id_digits:2 + id_digits + 2 * dlc])
                if len(data) != dlc:
                    raise ValueError("short frame")
                self.pty.write_bytes(b"z\r" if code == "t" else b"Z\r")  # Lawicel: sent
                return can.Message(arbitration_id=int(line[1:1 + id_digits], 16), data=data,
                                   is_extended_id=code == "T")
        except (ValueError, IndexError):
            self.bad_lines += 1
            self.pty.write_bytes(self.ERROR)
            return None
        if code in ("O", "L"):
            self.is_open = True
        elif code == "C":
            self.is_open = False
        elif code == "V":
            self.pty.write_bytes(b"V1013\r")
            return None
        elif code not in ("S", "s", "Y", "Z", "F", "N", ""):
            self.bad_lines += 1
            self.pty.write_bytes(self.ERROR)
            return None
        self.pty.write_bytes(self.OK)
        return None

    def write(self, units: list[can.Message]) -> None:
        if not self.is_open:
            return  # a closed channel forwards nothing, as on a real adapter
        lines = []
        for frame in units:
            if frame.is_error_frame:
                continue  # the Lawicel SLCAN protocol has no error frame
            ident = f"T{frame.arbitration_id:08X}" if frame.is_extended_id else f"t{frame.arbitration_id:03X}"
            lines.append(f"{ident}{frame.dlc}{bytes(frame.data).hex().upper()}\r".encode())
        self.pty.write_bytes(b"".join(lines))

    def close(self) -> None:
        self.pty.close()


def _pty(path: str) -> PtyPort:
    from hand_service.errors import UserError

    try:
        return PtyPort(path)
    except OSError as exc:
        raise UserError(f"cannot play the device at {path}: {exc.strerror or exc} (--port: an existing "
                        "terminal, or a new path for a pseudo-terminal's symlink)") from None


def open_port(profile: Any, port: str | None) -> FirmwarePort:
    """The firmware's port for a profile: a pty (serial, slcan) or a python-can bus."""
    from hand_service.errors import UserError
    from hand_service.transports.can_transport import bus_arguments

    settings = profile.transport
    kind = settings["kind"]
    if kind == "serial":
        return _pty(port or settings["port"])
    if kind != "can":
        raise UserError(f"{profile.path}: transport {kind} has no firmware to mock; use a can or "
                        "serial profile (can-v1-slcan.yaml, serial-v1.yaml)")
    if settings["interface"] == "virtual":
        raise UserError(f"{profile.path}: python-can's virtual bus lives inside one process, so the "
                        "mock cannot join it from another; use can-v1-slcan.yaml, or run the mock in "
                        "a thread (hand_service.firmware.board.run_in_thread)")
    if settings["interface"] == "slcan":
        return SlcanAdapterPort(_pty(port or settings["channel"]))
    channel = port or settings["channel"]
    try:
        return CanBusPort(can.Bus(**{**bus_arguments(settings), "channel": channel}))
    except (can.CanError, OSError, ValueError) as exc:
        raise UserError(f"cannot open CAN {settings['interface']}:{channel}: {exc}") from None
