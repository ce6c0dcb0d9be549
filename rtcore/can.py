"""The host's can-v1 codec in C (rtcore_can, csrc/rtcore_can.c) on the Python side.

The pack and unpack are what cantools generates from firmware_profiles/can-v1.dbc when the
extension is built. Here: the codec struct (`CanCore`: one frame decoded, one message
encoded), the batch and the tick over it (`CanTickCore`: frames added by a reader thread,
one C call per tick), and the E2E CRC. Messages are rtcore_can_message structs (`message()`
makes one); hand_service.wire.can_c_codec turns them into the protocol's messages.
"""

from __future__ import annotations

import struct
from typing import Any

from rtcore._rtcore import ffi, lib

NONE = lib.RTCORE_CAN_NONE
SENSOR = lib.RTCORE_CAN_SENSOR
VALVE = lib.RTCORE_CAN_VALVE
STATUS = lib.RTCORE_CAN_STATUS
VERSION = lib.RTCORE_CAN_VERSION
VERSION_REQUEST = lib.RTCORE_CAN_VERSION_REQUEST
FAULT_INJECT = lib.RTCORE_CAN_FAULT_INJECT
NO_FRAME = lib.RTCORE_CAN_NO_FRAME  # the id of an error or remote frame
FRAME_BYTES = lib.RTCORE_CAN_FRAME_BYTES
# the phases of a tick over can-v1, in order (rtcore_can_io.phase_ns, CanTickCore.phase_ns)
PHASES = ("decode", "control", "encode", "follow")
assert len(PHASES) == lib.RTCORE_CAN_PHASES
PHASE_INDEX = (lib.RTCORE_CAN_PHASE_DECODE, lib.RTCORE_CAN_PHASE_CONTROL, lib.RTCORE_CAN_PHASE_ENCODE,
               lib.RTCORE_CAN_PHASE_FOLLOW)
assert tuple(range(len(PHASES))) == PHASE_INDEX
MAX_FINGERS = lib.RTCORE_MAX_FINGERS
MESSAGE_BYTES = ffi.sizeof("rtcore_can_message")
# rtcore_can_io from n_tx to tx_data's end: n_tx, tx_id[], tx_len[], tx_data[] (one copy per tick)
TX_OFFSET = ffi.offsetof("rtcore_can_io", "n_tx")
TX_LAYOUT = struct.Struct(f"=i{MAX_FINGERS}i{MAX_FINGERS}i{MAX_FINGERS * FRAME_BYTES}s")
TX_END = TX_OFFSET + TX_LAYOUT.size
assert ffi.offsetof("rtcore_can_io", "tx_data") == TX_END - MAX_FINGERS * FRAME_BYTES


def e2e_crc(data: bytes, data_id: int) -> int:
    """AUTOSAR E2E profile-2 CRC-8 over data[1:] and data_id."""
    return int(lib.rtcore_can_e2e_crc(data, len(data), data_id))


def message() -> Any:
    """A zeroed rtcore_can_message (kind NONE)."""
    return ffi.new("rtcore_can_message *")


def tx_frames(tx: bytes) -> list[tuple[int, bytes]]:
    """The (id, data) frames in a copy of an io's tx part (CanTickCore.tx)."""
    values = TX_LAYOUT.unpack(tx)
    n, data = values[0], values[-1]
    ids, lens = values[1:1 + MAX_FINGERS], values[1 + MAX_FINGERS:1 + 2 * MAX_FINGERS]
    return [(ids[k], data[k * FRAME_BYTES:k * FRAME_BYTES + lens[k]]) for k in range(n)]


class CanCore:
    """An rtcore_can: n_fingers and the ranges of the DBC's signals (low, high pairs)."""

    def __init__(self, n_fingers: int, flex_mv: tuple[float, float], pressure_meas_kpa: tuple[float, float],
                 command_kpa: tuple[float, float]) -> None:
        self.c = ffi.new("rtcore_can *")
        self._ranges = (*flex_mv, *pressure_meas_kpa, *command_kpa)
        self.n_fingers = n_fingers
        self.init()
        self._out = message()
        self._ids = ffi.new("int32_t[]", MAX_FINGERS)
        self._lens = ffi.new("int32_t[]", MAX_FINGERS)
        self._data = ffi.new("uint8_t[]", MAX_FINGERS * FRAME_BYTES)

    def init(self) -> None:
        """As new: nothing being reassembled, every counter 0."""
        lib.rtcore_can_init(self.c, self.n_fingers, *self._ranges)

    def reset(self) -> None:
        """Forget what is being reassembled and the last sample taken; the counters stay."""
        lib.rtcore_can_reset(self.c)

    def decode(self, frame_id: int, data: bytes) -> Any | None:
        """The message this frame completes (an rtcore_can_message, valid until the next
        call), or None. Bad frames are counted (counters())."""
        return self._out if lib.rtcore_can_decode(self.c, frame_id, data, len(data), self._out) else None

    def encode(self, m: Any) -> list[tuple[int, bytes]] | None:
        """The (id, data) frames of message m, or None when the wire cannot carry it."""
        n = lib.rtcore_can_encode(self.c, m, self._ids, self._lens, self._data, MAX_FINGERS)
        if n < 0:
            return None
        raw = ffi.buffer(self._data)
        return [(self._ids[k], raw[k * FRAME_BYTES:k * FRAME_BYTES + self._lens[k]]) for k in range(n)]

    def counters(self) -> tuple[int, int, int, int, int]:
        """frames, crc_errors, decode_errors, ignored, incomplete."""
        c = self.c
        return c.frames, c.crc_errors, c.decode_errors, c.ignored, c.incomplete

    @property
    def last_error(self) -> int:
        """The kind of the newest bad frame (NONE: an unknown id)."""
        return int(self.c.last_error)

    def forget_last_sample(self) -> None:
        self.c.has_last_sample = 0


class CanTickCore:
    """The batch of received frames and the tick over it, on a CanCore and an rtcore_tick."""

    def __init__(self, core: CanCore, c_tick: Any) -> None:
        self.core = core
        self.io = io = ffi.new("rtcore_can_io *")
        self._add = lib.rtcore_can_rx_add
        self._buffer = ffi.buffer(io)
        args = (c_tick, core.c, io)
        self._tick, self._tick_at = lib.rtcore_can_tick, lib.rtcore_can_tick_at
        self._args = args

    def add(self, frame_id: int, data: bytes, received_s: float) -> bool:
        """A received frame into the next tick's batch (any thread); False: the batch is full."""
        return bool(self._add(self.io, frame_id, data, len(data), received_s))

    def clear(self) -> None:
        """Drop the batch (a new connection; the caller is the thread that adds)."""
        self.io.n_rx = 0

    def tick(self, refs: int, vent: bool, missed_last: bool, woke_ns: int, command_sequence: int) -> int:
        """rtcore_can_tick: the RTCORE_TICK_* bits."""
        return self._tick(*self._args, refs, vent, missed_last, woke_ns, command_sequence)

    def tick_at(self, deadline_ns: int, spin_ns: int, refs: int, vent: bool, missed_last: bool,
                command_sequence: int, times_ns: Any) -> int:
        """rtcore_can_tick_at: the RTCORE_TICK_* bits, or -1 when the sleep failed."""
        return self._tick_at(*self._args, deadline_ns, spin_ns, refs, vent, missed_last, command_sequence,
                             times_ns)

    def tx(self) -> bytes:
        """A copy of the command frames the last tick encoded (tx_frames reads it)."""
        return self._buffer[TX_OFFSET:TX_END]

    @property
    def samples(self) -> int:
        """The samples the last tick took (0: none fresh)."""
        return int(self.io.samples)

    @property
    def sample_sequence(self) -> int:
        """The wire sequence of the newest sample taken."""
        return int(self.io.sample.sequence)

    @property
    def phase_ns(self) -> tuple[int, ...]:
        """How long each phase of the last tick ran (ns, in the order of PHASES); their sum is
        the tick's time from its start to the end of the follow check."""
        return tuple(self.io.phase_ns)

    @property
    def dropped(self) -> int:
        """Frames that found the batch full."""
        return int(self.io.rx_dropped)

    @property
    def busy_ticks(self) -> int:
        """Ticks that found the reader thread adding a frame, and left the batch to the next."""
        return int(self.io.busy_ticks)


__all__ = ["FAULT_INJECT", "FRAME_BYTES", "MAX_FINGERS", "NONE", "NO_FRAME", "PHASES", "SENSOR", "STATUS",
           "VALVE", "VERSION", "VERSION_REQUEST", "CanCore", "CanTickCore", "e2e_crc", "message", "tx_frames"]
