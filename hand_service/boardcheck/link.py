"""The check's side of the wire: serial-v1 on a serial port, or can-v1 on a python-can bus.

Besides the messages a host sends, a BoardLink sends what a good host never does, to see
the board throw it away: a frame with a bad CRC, a valve command for the wrong number of
fingers, and rubbish (bytes with no frame in them on serial-v1; a frame with an id the
protocol does not use on can-v1). Everything received is timed on the host's monotonic
clock; serial-v1 frames keep their header sequence, which the stream check follows.
"""

from __future__ import annotations

import time
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Any

import can
import serial

from hand_service.boardcheck.slcan import BulkSlcanBus
from hand_service.wire.can_codec import CanCodec
from hand_service.wire.framing import CRC_BYTES, FrameDecoder, encode_frame
from hand_service.wire.messages import DecodeStats, Message, ValveCommand
from hand_service.wire.serial_codec import MAX_FINGERS_ON_WIRE, SerialCodec

MAX_UNITS_PER_READ = 256
UNUSED_CAN_ID = 0x555  # no message of can-v1.dbc: a board must ignore it without counting it
SERIAL_RUBBISH = bytes(range(0x20, 0x60)) + b"\xa5\x5a\xff"  # no frame; ends in a false sync


@dataclass(frozen=True)
class Received:
    t_s: float  # host monotonic time of arrival
    message: Message
    frame_sequence: int | None = None  # serial-v1's header sequence (can-v1 has none)
    # how much later than it could have been this host read it: its own stalls since it last
    # looked at the link (session.py); the board is not to blame for them
    late_s: float = 0.0
    # a stall of this host just before that look, which a board on the same machine may have
    # shared and caught up after (session.py): excused in a gap between samples only
    grace_s: float = 0.0

    @property
    def board_t_s(self) -> float:
        """The arrival time less this host's own lateness: what the board is judged by."""
        return self.t_s - self.late_s


@dataclass(frozen=True)
class InvalidSent:
    """What send_invalid() wrote: frames the board must count in rx_errors, and rubbish it must not."""

    bad_frames: int
    rubbish_units: int


class BoardLink(ABC):
    description = ""

    @abstractmethod
    def send(self, message: Message) -> None: ...

    @abstractmethod
    def send_invalid(self, command: ValveCommand, then: ValveCommand | None = None) -> InvalidSent:
        """`command` with a bad CRC, `command` for the wrong finger count, rubbish; then the
        good command `then` right behind the rubbish (a receiver must still find it)."""

    @abstractmethod
    def receive(self, timeout_s: float) -> list[Received]: ...

    @abstractmethod
    def stats(self) -> DecodeStats:
        """What the check's decoder threw away of what the board sent."""

    @abstractmethod
    def close(self) -> None: ...


def _other_finger_count(n: int) -> int:
    return n + 1 if n < MAX_FINGERS_ON_WIRE else n - 1


class SerialBoardLink(BoardLink):
    def __init__(self, port: str, baudrate_bps: int, n_fingers: int) -> None:
        self.description = f"serial-v1 on {port}"
        self.n_fingers = n_fingers
        self.port = serial.Serial(port, baudrate_bps, timeout=0.0, write_timeout=0.5)
        self.port.reset_input_buffer()  # what the board sent before anyone listened is not an answer
        self.codec = SerialCodec(n_fingers)  # encodes the host's frames, with their sequence
        self._reader = SerialCodec(n_fingers)  # decodes the board's messages, frame by frame
        self._frames = FrameDecoder()

    def send(self, message: Message) -> None:
        self.port.write(b"".join(self.codec.encode(message)))

    def send_invalid(self, command: ValveCommand, then: ValveCommand | None = None) -> InvalidSent:
        good = self.codec.encode(command)[0]
        bad_crc = good[:-CRC_BYTES] + bytes(b ^ 0x01 for b in good[-CRC_BYTES:])
        wrong_n = _other_finger_count(self.n_fingers)
        wrong_fingers = SerialCodec(wrong_n).encode(
            ValveCommand(command.sequence, command.pressure_cmd_kpa[:1] * wrong_n))[0]
        follow = b"".join(self.codec.encode(then)) if then is not None else b""
        self.port.write(bad_crc + wrong_fingers + SERIAL_RUBBISH + follow)
        return InvalidSent(bad_frames=2, rubbish_units=1)

    def receive(self, timeout_s: float) -> list[Received]:
        self.port.timeout = max(0.0, timeout_s)
        first = self.port.read(1)
        if not first:
            return []
        data = first + self.port.read(self.port.in_waiting)
        now = time.monotonic()
        out = []
        for frame in self._frames.feed(data):
            for message in self._reader.decode(encode_frame(frame.sequence, frame.type, frame.payload)):
                out.append(Received(now, message, frame.sequence))
        return out

    def stats(self) -> DecodeStats:
        frames, messages = self._frames.stats, self._reader.stats
        return DecodeStats(frames=frames.frames, crc_errors=frames.crc_errors,
                           decode_errors=messages.decode_errors, garbage_bytes=frames.garbage_bytes,
                           frame_gaps=frames.frame_gaps, errors=[*frames.errors, *messages.errors][-8:])

    def close(self) -> None:
        self.port.close()


class CanBoardLink(BoardLink):
    def __init__(self, bus_arguments: dict[str, Any], dbc_path: str, n_fingers: int) -> None:
        self.description = f"can-v1 on {bus_arguments['interface']}:{bus_arguments['channel']}"
        self.n_fingers = n_fingers
        self.codec = CanCodec(dbc_path, n_fingers)
        arguments = dict(bus_arguments)
        if arguments.pop("interface") == "slcan":  # python-can's, read in bulk (slcan.py)
            self.bus: can.BusABC = BulkSlcanBus(**arguments)
        else:
            self.bus = can.Bus(interface=bus_arguments["interface"], **arguments)

    def send(self, message: Message) -> None:
        for frame in self.codec.encode(message):
            self.bus.send(frame)

    def send_invalid(self, command: ValveCommand, then: ValveCommand | None = None) -> InvalidSent:
        first = self.codec.encode(command)[0]
        data = bytearray(first.data)
        data[0] ^= 0x01  # the E2E CRC-8
        bad_crc = can.Message(arbitration_id=first.arbitration_id, is_extended_id=False, data=data)
        short = can.Message(arbitration_id=first.arbitration_id, is_extended_id=False,
                            data=bytes(first.data)[:-1])
        rubbish = can.Message(arbitration_id=UNUSED_CAN_ID, is_extended_id=False, data=bytes(8))
        for frame in (bad_crc, short, rubbish):
            self.bus.send(frame)
        if then is not None:
            self.send(then)
        return InvalidSent(bad_frames=2, rubbish_units=1)

    def receive(self, timeout_s: float) -> list[Received]:
        out: list[Received] = []
        wait = max(0.0, timeout_s)
        for _ in range(MAX_UNITS_PER_READ):
            try:
                frame = self.bus.recv(wait)
            except (ValueError, IndexError, can.CanOperationError):
                continue  # a garbled SLCAN line: the adapter's, not the board's
            if frame is None:
                break
            now = time.monotonic()
            out.extend(Received(now, message) for message in self.codec.decode(frame))
            wait = 0.0
        return out

    def stats(self) -> DecodeStats:
        return self.codec.stats

    def close(self) -> None:
        self.bus.shutdown()
