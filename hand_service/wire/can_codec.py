"""Protocol messages <-> CAN frames, encoded and decoded by cantools from the profile's DBC.

Byte 0 of every frame is an AUTOSAR E2E profile-2 CRC-8 (cantools.autosar) over the rest
of the frame and a data id (the low byte of the frame id), so a corrupted payload is
caught even where the bus's own CRC cannot see it (a firmware bug, an SLCAN line).
Sensor and valve messages travel as one frame per finger and are reassembled here.

A reading the board does not have (NaN: a board without pressure sensing) travels as the
raw value the DBC's value table names `not_reported` and decodes to NaN; a reading beyond
its signal's range is sent at the range's end (the sensor is off the scale). A command is
never clipped: one the signal cannot carry is refused with ValueError.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import can
import cantools
from cantools.autosar.end_to_end import apply_profile2_crc, check_profile2_crc

from hand_service.errors import UserError
from hand_service.wire.messages import (
    SEQUENCE_MODULO,
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

NOT_REPORTED = "not_reported"  # the value-table name of a measured signal's "no reading" raw value
MEASURED = ("flex_mv", "pressure_meas_kpa")  # SensorFinger's readings

# The messages and signals this project needs from a DBC; a lab's DBC may hold more.
REQUIRED_SIGNALS: dict[str, tuple[str, ...]] = {
    "SensorFinger": ("e2e_crc", "finger_index", "sequence", "command_sequence", "flex_mv",
                     "pressure_meas_kpa"),
    "ValveCommand": ("e2e_crc", "finger_index", "sequence", "pressure_cmd_kpa"),
    "Status": ("e2e_crc", "state", "fault_active", "rx_errors", "uptime_ms", "fault_code"),
    "FirmwareVersion": ("e2e_crc", "protocol_version", "firmware_major", "firmware_minor",
                        "firmware_patch", "finger_count"),
    "VersionRequest": ("e2e_crc", "protocol_version"),
    "FaultInject": ("e2e_crc", "fault", "finger_index", "duration_ms", "value"),
}


def load_dbc(path: str | Path) -> cantools.database.can.Database:
    """Load a DBC and check it holds every message and signal the protocol needs."""
    try:
        db = cantools.database.load_file(str(path), database_format="dbc", strict=True)
    except FileNotFoundError:
        raise UserError(f"{path}: DBC file not found") from None
    except Exception as exc:  # cantools raises several parser errors
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise UserError(f"{path}: not a valid DBC: {first}") from None
    names = {m.name for m in db.messages}
    for name, signals in REQUIRED_SIGNALS.items():
        if name not in names:
            raise UserError(f"{path}: the DBC has no message '{name}' (protocol needs "
                            f"{', '.join(REQUIRED_SIGNALS)})")
        have = {s.name for s in db.get_message_by_name(name).signals}
        missing = [s for s in signals if s not in have]
        if missing:
            raise UserError(f"{path}: message '{name}' lacks signal(s) {', '.join(missing)}")
    return db


def signal_range(sig: Any) -> tuple[float, float]:
    """The physical range a signal carries: its declared [min|max] within what its raw bits hold."""
    if sig.is_float:
        return (-math.inf if sig.minimum is None else float(sig.minimum),
                math.inf if sig.maximum is None else float(sig.maximum))
    bits = sig.length
    raw_low, raw_high = (-(2 ** (bits - 1)), 2 ** (bits - 1) - 1) if sig.is_signed else (0, 2**bits - 1)
    ends = sorted(raw * sig.scale + sig.offset for raw in (raw_low, raw_high))
    low = ends[0] if sig.minimum is None else max(ends[0], float(sig.minimum))
    high = ends[1] if sig.maximum is None else min(ends[1], float(sig.maximum))
    return low, high


def _not_reported(sig: Any) -> frozenset[float]:
    """The physical values a reading takes when the board has none: the raw values its
    value table names not_reported, scaled as decode() scales them."""
    return frozenset(raw * sig.scale + sig.offset for raw, name in (sig.choices or {}).items()
                     if str(name) == NOT_REPORTED)


@dataclass
class _Partial:
    """A multi-frame message being reassembled: one slot per finger."""

    sequence: int
    values: dict[int, tuple[float, ...]]
    command_sequence: int = 0


class CanCodec:
    """Encode messages to python-can frames and decode frames back, reassembling fingers."""

    def __init__(self, dbc_path: str | Path, n_fingers: int) -> None:
        self.db = load_dbc(dbc_path)
        self.n_fingers = n_fingers
        self.stats = DecodeStats()
        self._msg = {name: self.db.get_message_by_name(name) for name in REQUIRED_SIGNALS}
        self._name_by_id = {m.frame_id: name for name, m in self._msg.items()}
        self._partial: dict[str, _Partial | None] = {"SensorFinger": None, "ValveCommand": None}
        sensor = self._msg["SensorFinger"]
        self._no_reading = {s: _not_reported(sensor.get_signal_by_name(s)) for s in MEASURED}
        self._command_range = self.command_range_kpa()

    # -- encoding -------------------------------------------------------------------------

    def signal_range(self, message: str, signal: str) -> tuple[float, float]:
        return signal_range(self._msg[message].get_signal_by_name(signal))

    def command_range_kpa(self) -> tuple[float, float]:
        """The pressure commands this DBC's ValveCommand carries (kPa)."""
        return self.signal_range("ValveCommand", "pressure_cmd_kpa")

    def carries_nan(self, signal: str) -> bool:
        """A NaN reading of this SensorFinger signal can cross (its value table has not_reported)."""
        sig = self._msg["SensorFinger"].get_signal_by_name(signal)
        return NOT_REPORTED in (sig.choices or {}).values()

    def _reading(self, signal: str, value: float) -> float | str:
        """A sensor reading as the board sends it: NaN as the signal's not_reported raw value,
        anything beyond the range at the range's end (the sensor is off the scale)."""
        if math.isnan(value):
            sig = self._msg["SensorFinger"].get_signal_by_name(signal)
            if NOT_REPORTED not in (sig.choices or {}).values():
                raise ValueError(f"SensorFinger.{signal} is NaN, and the DBC reserves no "
                                 f"'{NOT_REPORTED}' value for it")
            return NOT_REPORTED
        low, high = self.signal_range("SensorFinger", signal)
        return min(max(value, low), high)

    def _command(self, kpa: float) -> float:
        low, high = self._command_range
        if not low <= kpa <= high:  # NaN too
            raise ValueError(f"pressure command {kpa:g} kPa: ValveCommand.pressure_cmd_kpa carries "
                             f"{low:g}..{high:g} kPa only")
        return kpa

    def _frame(self, name: str, data: dict[str, Any]) -> can.Message:
        msg = self._msg[name]
        payload = msg.encode({"e2e_crc": 0, **data}, strict=True)
        payload = apply_profile2_crc(payload, msg.frame_id & 0xFF)
        return can.Message(arbitration_id=msg.frame_id, is_extended_id=msg.is_extended_frame,
                           data=payload)

    def encode(self, message: Message) -> list[can.Message]:
        if isinstance(message, SensorReport):
            return [self._frame("SensorFinger", {
                "finger_index": i, "sequence": message.sequence % SEQUENCE_MODULO,
                "command_sequence": message.command_sequence % SEQUENCE_MODULO,
                "flex_mv": self._reading("flex_mv", mv),
                "pressure_meas_kpa": self._reading("pressure_meas_kpa", kpa)})
                for i, (mv, kpa) in enumerate(zip(message.sensor_mv, message.pressure_meas_kpa,
                                                  strict=True))]
        if isinstance(message, ValveCommand):
            return [self._frame("ValveCommand", {
                "finger_index": i, "sequence": message.sequence % SEQUENCE_MODULO,
                "pressure_cmd_kpa": self._command(kpa)})
                for i, kpa in enumerate(message.pressure_cmd_kpa)]
        if isinstance(message, Status):
            return [self._frame("Status", {"state": int(message.state), "uptime_ms": message.uptime_ms
                                           % 2**32, "fault_active": int(message.fault_active),
                                           "rx_errors": min(message.rx_errors, 255),
                                           "fault_code": int(message.fault_code)})]
        if isinstance(message, VersionInfo):
            major, minor, patch = message.firmware_version
            return [self._frame("FirmwareVersion", {
                "protocol_version": message.protocol_version, "firmware_major": major,
                "firmware_minor": minor, "firmware_patch": patch,
                "finger_count": message.finger_count})]
        if isinstance(message, VersionRequest):
            return [self._frame("VersionRequest", {"protocol_version": message.protocol_version})]
        if isinstance(message, FaultRequest):
            return [self._frame("FaultInject", {
                "fault": int(message.kind), "finger_index": message.finger_index,
                "duration_ms": message.duration_ms, "value": message.value})]
        raise TypeError(f"cannot encode {message!r}")

    # -- decoding -------------------------------------------------------------------------

    def decode(self, frame: can.Message) -> list[Message]:
        """The messages this frame completes (often none). Bad frames are counted, never raised."""
        if frame.is_error_frame or frame.is_remote_frame:
            self.stats.ignored += 1
            return []
        name = self._name_by_id.get(frame.arbitration_id)
        if name is None:
            self.stats.ignored += 1
            return []
        msg = self._msg[name]
        data = bytes(frame.data)
        if len(data) != msg.length:
            self.stats.decode_errors += 1
            self.stats.note(f"{name} frame of {len(data)} bytes, expected {msg.length}")
            return []
        if not check_profile2_crc(data, msg.frame_id & 0xFF):
            self.stats.crc_errors += 1
            self.stats.note(f"{name} frame 0x{msg.frame_id:03X} failed its E2E CRC")
            return []
        try:
            # numbers only: a lab's DBC may give any signal a value table
            values = msg.decode(data, decode_choices=False, scaling=True)
            self.stats.frames += 1
            return self._message(name, values)
        except (ValueError, KeyError, cantools.database.DecodeError) as exc:
            self.stats.decode_errors += 1
            self.stats.note(f"{name}: {exc}")
            return []

    def _measured(self, signal: str, value: float) -> float:
        """A decoded reading: the not_reported value is no reading at all (NaN)."""
        return math.nan if value in self._no_reading[signal] else float(value)

    def _message(self, name: str, v: dict[str, Any]) -> list[Message]:
        if name == "SensorFinger":
            return self._assemble(name, v, tuple(self._measured(s, v[s]) for s in MEASURED))
        if name == "ValveCommand":
            return self._assemble(name, v, (float(v["pressure_cmd_kpa"]),))
        if name == "Status":
            return [Status(FirmwareState(int(v["state"])), int(v["uptime_ms"]),
                           FaultKind(int(v["fault_active"])), int(v["rx_errors"]),
                           firmware_fault(int(v["fault_code"])))]
        if name == "FirmwareVersion":
            return [VersionInfo(int(v["protocol_version"]), (int(v["firmware_major"]),
                                int(v["firmware_minor"]), int(v["firmware_patch"])),
                                int(v["finger_count"]))]
        if name == "VersionRequest":
            return [VersionRequest(int(v["protocol_version"]))]
        return [FaultRequest(FaultKind(int(v["fault"])), int(v["finger_index"]),
                             int(v["duration_ms"]), int(v["value"]))]

    def _assemble(self, name: str, v: dict[str, Any], values: tuple[float, ...]) -> list[Message]:
        finger, sequence = int(v["finger_index"]), int(v["sequence"])
        if finger >= self.n_fingers:
            raise ValueError(f"finger_index {finger} beyond the hand's {self.n_fingers} fingers")
        partial = self._partial[name]
        if partial is None or partial.sequence != sequence:
            if partial is not None:
                self.stats.incomplete += 1
            partial = _Partial(sequence, {}, int(v.get("command_sequence", 0)))
            self._partial[name] = partial
        partial.values[finger] = values
        if len(partial.values) < self.n_fingers:
            return []
        self._partial[name] = None
        ordered = [partial.values[i] for i in range(self.n_fingers)]
        if name == "ValveCommand":
            return [ValveCommand(sequence, [x[0] for x in ordered])]
        return [SensorReport(sequence, partial.command_sequence, [x[0] for x in ordered],
                             [x[1] for x in ordered])]
