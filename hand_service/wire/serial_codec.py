"""Protocol messages <-> serial-v1 frames (framing.py); payload layouts in one table.

Payloads are little-endian; the layouts are documented in docs/serial-protocol.md and
checked against this table by a test.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

from hand_service.wire.framing import MAX_PAYLOAD, FrameDecoder, encode_frame
from hand_service.wire.messages import (
    DecodeStats,
    FaultKind,
    FaultRequest,
    FirmwareState,
    Message,
    SensorReport,
    Status,
    ValveCommand,
    VersionInfo,
    VersionRequest,
    firmware_fault,
)


@dataclass(frozen=True)
class Layout:
    type: int
    header: struct.Struct  # fixed fields
    per_finger: struct.Struct | None = None  # repeated once per finger after the header


LAYOUTS: dict[type, Layout] = {
    SensorReport: Layout(0x10, struct.Struct("<BBB"), struct.Struct("<ff")),  # seq, cmd seq, n; mV, kPa
    ValveCommand: Layout(0x20, struct.Struct("<BB"), struct.Struct("<f")),  # seq, n; kPa
    Status: Layout(0x30, struct.Struct("<BBBIB")),  # state, fault_active, rx_errors, uptime_ms, fault_code
    VersionInfo: Layout(0x40, struct.Struct("<HBBBB")),  # protocol, major, minor, patch, fingers
    VersionRequest: Layout(0x41, struct.Struct("<H")),  # protocol the host expects
    FaultRequest: Layout(0x7E, struct.Struct("<BBHH")),  # kind, finger, duration_ms, value
}
BY_TYPE = {layout.type: cls for cls, layout in LAYOUTS.items()}
_SENSOR = LAYOUTS[SensorReport]
F32_MAX = struct.unpack("<f", b"\xff\xff\x7f\x7f")[0]
MAX_FINGERS_ON_WIRE = (MAX_PAYLOAD - _SENSOR.header.size) // _SENSOR.per_finger.size  # type: ignore[union-attr]


def _command(kpa: float) -> float:
    """A setpoint must be a number f32 holds: never clipped, never a NaN (a reading's NaN
    means "not reported", and crosses as it is)."""
    if not -F32_MAX <= kpa <= F32_MAX:
        raise ValueError(f"pressure command {kpa:g} kPa: serial-v1 carries finite f32 values only")
    return kpa


class SerialCodec:
    """Encode messages to framed bytes with a running sequence; decode a byte stream."""

    def __init__(self, n_fingers: int) -> None:
        if n_fingers > MAX_FINGERS_ON_WIRE:
            raise ValueError(f"serial-v1 carries at most {MAX_FINGERS_ON_WIRE} fingers")
        self.n_fingers = n_fingers
        self.stats = DecodeStats()
        self._decoder = FrameDecoder(self.stats)
        self._tx_sequence = 0

    @staticmethod
    def command_range_kpa() -> tuple[float, float]:
        """The pressure commands serial-v1 carries (kPa): any finite f32."""
        return -F32_MAX, F32_MAX

    def encode(self, message: Message) -> list[bytes]:
        layout = LAYOUTS[type(message)]
        if isinstance(message, SensorReport):
            head = layout.header.pack(message.sequence % 256, message.command_sequence % 256,
                                      len(message.sensor_mv))
            rows = zip(message.sensor_mv, message.pressure_meas_kpa, strict=True)
            payload = head + b"".join(layout.per_finger.pack(mv, kpa)  # type: ignore[union-attr]
                                      for mv, kpa in rows)
        elif isinstance(message, ValveCommand):
            head = layout.header.pack(message.sequence % 256, len(message.pressure_cmd_kpa))
            payload = head + b"".join(layout.per_finger.pack(_command(kpa))  # type: ignore[union-attr]
                                      for kpa in message.pressure_cmd_kpa)
        elif isinstance(message, Status):
            payload = layout.header.pack(int(message.state), int(message.fault_active),
                                         min(message.rx_errors, 255), message.uptime_ms % 2**32,
                                         int(message.fault_code))
        elif isinstance(message, VersionInfo):
            payload = layout.header.pack(message.protocol_version, *message.firmware_version,
                                         message.finger_count)
        elif isinstance(message, VersionRequest):
            payload = layout.header.pack(message.protocol_version)
        else:
            assert isinstance(message, FaultRequest)
            payload = layout.header.pack(int(message.kind), message.finger_index, message.duration_ms,
                                         message.value)
        frame = encode_frame(self._tx_sequence, layout.type, payload)
        self._tx_sequence = (self._tx_sequence + 1) % 256
        return [frame]

    def decode(self, chunk: bytes) -> list[Message]:
        """Messages completed by this chunk of the byte stream; bad input is counted."""
        out: list[Message] = []
        for frame in self._decoder.feed(chunk):
            try:
                out.append(self._message(frame.type, frame.payload))
            except (KeyError, ValueError, struct.error) as exc:
                self.stats.decode_errors += 1
                self.stats.note(f"serial frame type 0x{frame.type:02X}: {exc}")
        return out

    def reset(self) -> None:
        self._decoder.reset()

    def _message(self, type_: int, payload: bytes) -> Message:
        cls = BY_TYPE[type_]
        layout = LAYOUTS[cls]
        head = layout.header.unpack_from(payload)
        if layout.per_finger is None:
            if len(payload) != layout.header.size:
                raise ValueError(f"payload of {len(payload)} bytes, expected {layout.header.size}")
            return _fixed(cls, head)
        n = head[-1]
        if n != self.n_fingers or len(payload) != layout.header.size + n * layout.per_finger.size:
            raise ValueError(f"{n} fingers in {len(payload)} bytes; this hand has {self.n_fingers}")
        rows = list(layout.per_finger.iter_unpack(payload[layout.header.size:]))
        if cls is SensorReport:
            return SensorReport(head[0], head[1], [r[0] for r in rows], [r[1] for r in rows])
        return ValveCommand(head[0], [r[0] for r in rows])


def _fixed(cls: type, head: tuple) -> Message:
    if cls is Status:
        return Status(FirmwareState(head[0]), head[3], FaultKind(head[1]), head[2], firmware_fault(head[4]))
    if cls is VersionInfo:
        return VersionInfo(head[0], (head[1], head[2], head[3]), head[4])
    if cls is VersionRequest:
        return VersionRequest(head[0])
    return FaultRequest(FaultKind(head[0]), head[1], head[2], head[3])
