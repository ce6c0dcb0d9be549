"""The `serial` transport: a valve board on a serial port (pyserial), serial-v1 framing."""

from __future__ import annotations

from typing import Any

import serial

from hand_service.transports.link import Link, LinkTransport
from hand_service.wire.serial_codec import SerialCodec


class SerialLink(Link):
    def __init__(self, settings: dict[str, Any]) -> None:
        self.port_name = settings["port"]
        self.baudrate = settings["baudrate_bps"]
        self.description = f"serial {self.port_name}"
        self.port: serial.Serial | None = None

    def connect(self) -> None:
        self.port = serial.Serial(self.port_name, self.baudrate, timeout=0.01, write_timeout=0.5)

    def close(self) -> None:
        if self.port is not None:
            port, self.port = self.port, None
            port.close()

    def read(self, timeout_s: float) -> list[bytes]:
        assert self.port is not None
        self.port.timeout = timeout_s
        first = self.port.read(1)
        if not first:
            return []
        return [first + self.port.read(self.port.in_waiting)]

    def write(self, units: list[bytes]) -> None:
        assert self.port is not None
        self.port.write(b"".join(units))


class SerialTransport(LinkTransport):
    kind = "serial"

    def _make_codec(self) -> SerialCodec:
        return SerialCodec(self.n_fingers)

    def _make_link(self) -> Link:
        return SerialLink(self.settings)
