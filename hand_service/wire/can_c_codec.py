"""The can-v1 codec in C (csrc/rtcore_can.c), behind CanCodec's interface.

The C codec packs and unpacks with the code cantools generates from
firmware_profiles/can-v1.dbc when the extension is built, so it speaks that DBC's layout
only: `builtin_layout(dbc)` says whether a profile's DBC has it (a lab's DBC with other
frames, scales or bit positions keeps the Python codec, can_codec.py). The Python codec
stays the reference: tests/wire/test_c_can_codec.py holds the two to the same frames and
messages, frame for frame.
"""

from __future__ import annotations

import functools
from importlib import resources
from pathlib import Path
from typing import Any

import can

from hand_service.wire.can_codec import REQUIRED_SIGNALS, CanCodec, load_dbc
from hand_service.wire.messages import (
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
from rtcore import can as core

NAMES = {core.SENSOR: "SensorFinger", core.VALVE: "ValveCommand", core.STATUS: "Status",
         core.VERSION: "FirmwareVersion", core.VERSION_REQUEST: "VersionRequest",
         core.FAULT_INJECT: "FaultInject"}


def _layout(db: Any) -> tuple[Any, ...]:
    """What the generated C depends on: every required message's id and length, and every
    signal's bits, scaling and value table."""
    out = []
    for name in sorted(REQUIRED_SIGNALS):
        msg = db.get_message_by_name(name)
        signals = tuple(sorted((s.name, s.start, s.length, s.byte_order, s.is_signed, s.is_float,
                                float(s.scale), float(s.offset), s.minimum, s.maximum,
                                tuple(sorted((int(k), str(v)) for k, v in (s.choices or {}).items())))
                               for s in msg.signals))
        out.append((name, msg.frame_id, msg.length, msg.is_extended_frame, signals))
    return tuple(out)


@functools.lru_cache(maxsize=1)
def _builtin() -> tuple[Any, ...]:
    with resources.as_file(resources.files("hand_service.firmware_profiles") / "can-v1.dbc") as path:
        return _layout(load_dbc(path))


def builtin_layout(dbc_path: str | Path) -> bool:
    """The DBC lays out can-v1 as the C codec was generated from (firmware_profiles/can-v1.dbc)."""
    return _layout(load_dbc(dbc_path)) == _builtin()


def new_core(codec: CanCodec) -> core.CanCore:
    """An rtcore_can for codec's fingers, with the ranges of codec's DBC."""
    return core.CanCore(codec.n_fingers, codec.signal_range("SensorFinger", "flex_mv"),
                        codec.signal_range("SensorFinger", "pressure_meas_kpa"), codec.command_range_kpa())


def to_message(m: Any, n_fingers: int) -> Message:
    """A decoded rtcore_can_message as the Python codec's message."""
    kind = m.kind
    if kind == core.SENSOR:
        return SensorReport(m.sequence, m.command_sequence, [m.sensor_mv[i] for i in range(n_fingers)],
                            [m.pressure_meas_kpa[i] for i in range(n_fingers)])
    if kind == core.VALVE:
        return ValveCommand(m.sequence, [m.pressure_cmd_kpa[i] for i in range(n_fingers)])
    if kind == core.STATUS:
        return Status(FirmwareState(m.state), m.uptime_ms, FaultKind(m.fault_active), m.rx_errors,
                      firmware_fault(m.fault_code))
    if kind == core.VERSION:
        return VersionInfo(m.protocol_version, (m.firmware_major, m.firmware_minor, m.firmware_patch),
                           m.finger_count)
    if kind == core.VERSION_REQUEST:
        return VersionRequest(m.protocol_version)
    return FaultRequest(FaultKind(m.fault), m.finger_index, m.duration_ms, m.value)


def _fill(m: Any, message: Message) -> None:
    """An rtcore_can_message from a Python one. Values that no C field holds (an int beyond
    64 bits, a finger beyond RTCORE_MAX_FINGERS) raise ValueError, as the wire cannot carry them."""
    try:
        if isinstance(message, SensorReport):
            m.kind, m.sequence, m.command_sequence = core.SENSOR, message.sequence % 256, \
                message.command_sequence % 256
            m.n_fingers = len(message.sensor_mv)
            if len(message.pressure_meas_kpa) != m.n_fingers:
                raise ValueError("a sensor report with unequal readings")
            for i, (mv, kpa) in enumerate(zip(message.sensor_mv, message.pressure_meas_kpa, strict=True)):
                m.sensor_mv[i], m.pressure_meas_kpa[i] = mv, kpa
        elif isinstance(message, ValveCommand):
            m.kind, m.sequence = core.VALVE, message.sequence % 256
            m.n_fingers = len(message.pressure_cmd_kpa)
            for i, kpa in enumerate(message.pressure_cmd_kpa):
                m.pressure_cmd_kpa[i] = kpa
        elif isinstance(message, Status):
            m.kind, m.state = core.STATUS, int(message.state)
            m.fault_active = int(message.fault_active)
            m.rx_errors, m.fault_code = min(message.rx_errors, 255), int(message.fault_code)
            m.uptime_ms = message.uptime_ms % 2**32
        elif isinstance(message, VersionInfo):
            m.kind, m.protocol_version, m.finger_count = (core.VERSION, message.protocol_version,
                                                          message.finger_count)
            m.firmware_major, m.firmware_minor, m.firmware_patch = message.firmware_version
        elif isinstance(message, VersionRequest):
            m.kind, m.protocol_version = core.VERSION_REQUEST, message.protocol_version
        elif isinstance(message, FaultRequest):
            m.kind, m.fault = core.FAULT_INJECT, int(message.kind)
            m.finger_index = message.finger_index
            m.duration_ms, m.value = message.duration_ms, message.value
        else:
            raise TypeError(f"cannot encode {message!r}")
    except (OverflowError, IndexError) as exc:
        raise ValueError(f"{type(message).__name__}: a value the wire cannot carry ({exc})") from None


class CCanCodec(CanCodec):
    """CanCodec with its encode and decode in C; the counters in stats as the Python codec keeps them."""

    def __init__(self, dbc_path: str | Path, n_fingers: int) -> None:
        super().__init__(dbc_path, n_fingers)
        if not builtin_layout(dbc_path):
            raise ValueError(f"{dbc_path}: not the can-v1 layout the C codec was generated from")
        self.core = new_core(self)
        self._synced = (0, 0, 0, 0, 0)

    def reset(self) -> None:
        self.core.reset()
        self._synced = self.core.counters()  # the stats keep what they counted before

    def encode(self, message: Message) -> list[can.Message]:
        m = core.message()
        _fill(m, message)
        frames = self.core.encode(m)
        if frames is None:
            raise ValueError(f"{type(message).__name__}: a value the wire cannot carry")
        return [can.Message(arbitration_id=i, is_extended_id=False, data=data) for i, data in frames]

    def decode(self, frame: can.Message) -> list[Message]:
        frame_id = core.NO_FRAME if frame.is_error_frame or frame.is_remote_frame else frame.arbitration_id
        m = self.core.decode(frame_id, bytes(frame.data))  # C reads the bytes only at its message's length
        self.sync_stats()
        return [] if m is None else [to_message(m, self.n_fingers)]

    def sync_stats(self) -> None:
        """The C counters into stats (and a line for a new bad frame)."""
        now = self.core.counters()
        if now == self._synced:
            return
        name = NAMES.get(self.core.last_error, "a frame")
        if now[1] > self._synced[1]:
            self.stats.note(f"{name} frame failed its E2E CRC")
        if now[2] > self._synced[2]:
            self.stats.note(f"{name}: a frame this host cannot read")
        frames, crc, bad, ignored, incomplete = (n - o for n, o in zip(now, self._synced, strict=True))
        self._synced = now
        # added, not copied: the link counts into the same stats (an SLCAN line the adapter's
        # parser cannot read is a decode error the C codec never sees)
        s = self.stats
        s.frames += frames
        s.crc_errors += crc
        s.decode_errors += bad
        s.ignored += ignored
        s.incomplete += incomplete
