"""serial-v1 framing: sync, length, sequence, type, payload, CRC-16 (docs/serial-protocol.md).

    offset  size  field
    0       2     sync 0xA5 0x5A
    2       1     payload length L (0..MAX_PAYLOAD)
    3       1     sequence, per direction, wraps at 256
    4       1     message type
    5       L     payload
    5+L     2     CRC-16/CCITT-FALSE of bytes 2..4+L, little-endian

The decoder streams: feed it any chunk of bytes and it returns the frames completed. After
garbage or a bad CRC it hunts for the next sync one byte further on, so a good frame
that follows (or hides inside) rubbish is still found, as Klipper's host does with its
sync byte and MAVLink with its start byte.
"""

from __future__ import annotations

import binascii
from dataclasses import dataclass

from hand_service.wire.messages import DecodeStats, sequence_delta

SYNC = b"\xa5\x5a"
HEADER_BYTES = 5
CRC_BYTES = 2
MAX_PAYLOAD = 64
OVERHEAD_BYTES = HEADER_BYTES + CRC_BYTES


def crc16(data: bytes) -> int:
    """CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF): the standard library's crc_hqx."""
    return binascii.crc_hqx(data, 0xFFFF)


@dataclass(frozen=True)
class Frame:
    sequence: int
    type: int
    payload: bytes


def encode_frame(sequence: int, type_: int, payload: bytes) -> bytes:
    if len(payload) > MAX_PAYLOAD:
        raise ValueError(f"payload of {len(payload)} bytes exceeds {MAX_PAYLOAD}")
    body = bytes((len(payload), sequence % 256, type_)) + payload
    return SYNC + body + crc16(body).to_bytes(CRC_BYTES, "little")


class FrameDecoder:
    """Streaming decoder: bytes in, whole frames out; garbage and bad CRCs are counted."""

    def __init__(self, stats: DecodeStats | None = None) -> None:
        self.stats = stats or DecodeStats()
        self._buffer = bytearray()
        self._last_sequence: int | None = None

    def feed(self, data: bytes) -> list[Frame]:
        buf = self._buffer
        buf += data
        frames: list[Frame] = []
        while True:
            start = buf.find(SYNC)
            if start < 0:
                keep = 1 if buf[-1:] == SYNC[:1] else 0  # half a sync may end the chunk
                self.stats.garbage_bytes += len(buf) - keep
                del buf[:len(buf) - keep]
                break
            if start:
                self.stats.garbage_bytes += start
                del buf[:start]
            if len(buf) < HEADER_BYTES:
                break
            length = buf[2]
            if length > MAX_PAYLOAD:  # a sync pattern inside rubbish: hunt on
                self.stats.garbage_bytes += 1
                del buf[:1]
                continue
            end = HEADER_BYTES + length + CRC_BYTES
            if len(buf) < end:
                break
            body = bytes(buf[2:HEADER_BYTES + length])
            if int.from_bytes(buf[end - CRC_BYTES:end], "little") != crc16(body):
                self.stats.crc_errors += 1
                self.stats.note(f"serial frame with a bad CRC (type 0x{buf[4]:02X}, {length} bytes)")
                del buf[:1]
                continue
            frame = Frame(buf[3], buf[4], body[3:])
            del buf[:end]
            self.stats.frames += 1
            if self._last_sequence is not None:
                delta = sequence_delta(frame.sequence, self._last_sequence)
                if 0 < delta < 128:  # further back: a restart of the other end
                    self.stats.frame_gaps += delta - 1
            self._last_sequence = frame.sequence
            frames.append(frame)
        return frames

    def reset(self) -> None:
        """Forget a half-received frame (after a reconnect)."""
        self._buffer.clear()
        self._last_sequence = None
