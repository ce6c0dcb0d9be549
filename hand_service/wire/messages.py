"""The valve-board protocol as plain data: what crosses the wire, in either direction.

Sequence numbers are 8-bit and wrap. Sensor and valve messages hold every finger of
the hand; a codec may split them into several frames (CAN: one per finger).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import IntEnum

SEQUENCE_MODULO = 256
ALL_FINGERS = 255  # finger_index of a fault request that hits every finger


class FirmwareState(IntEnum):
    BOOTING = 0  # silent, valves vented
    IDLE = 1  # valves vented, waiting for the first valid command
    RUNNING = 2  # applying the host's setpoints
    WATCHDOG_VENTED = 3  # no valid command within the watchdog time: every valve vented
    FAULT = 4  # a fault of the board's own (FirmwareFault): every valve vented, commands ignored


class FirmwareFault(IntEnum):
    """A fault the board finds in itself (Status.fault_code); it vents and ignores commands."""

    NONE = 0
    VALVE_DRIVER = 1  # a valve driver reports an open load, a short or over-temperature
    PRESSURE_SENSOR = 2  # a chamber pressure sensor failed its plausibility check
    OVER_PRESSURE = 3  # a chamber went past the board's own hardware limit
    INTERNAL = 4  # the board's self-test failed (memory, clock, supply)


def firmware_fault(code: int) -> FirmwareFault | int:
    """A fault code off the wire: a newer board may know faults this host does not, and an
    unknown fault is still a fault (kept as its number)."""
    return FirmwareFault(code) if code in FirmwareFault._value2member_map_ else code


def fault_name(code: int) -> str:
    """The name of a FirmwareFault code ("" for none)."""
    if not code:
        return ""
    return FirmwareFault(code).name.lower() if code in FirmwareFault._value2member_map_ else "unknown"


class FaultKind(IntEnum):
    """Faults the mock firmware injects on request (its debug port)."""

    CLEAR = 0  # end every active fault
    DROP = 1  # drop `value` % of outgoing frames
    DELAY = 2  # hold every outgoing frame for `value` ms
    CORRUPT = 3  # flip a bit in `value` % of outgoing frames
    STUCK_SENSOR = 4  # the finger's sensor repeats its last reading
    SENSOR_OUT_OF_RANGE = 5  # the finger's sensor reads `value` mV (default: the wire's maximum)
    SILENCE = 6  # send nothing at all
    REBOOT = 7  # reset now: vent, go silent for `value` ms (default 200), announce again
    FIRMWARE_FAULT = 8  # the board finds a fault of its own: FirmwareFault `value` (default 1)
    PRESSURE_NAN = 9  # the finger's chamber pressure reads NaN (not reported)
    PRESSURE_STUCK = 10  # the finger's chamber pressure repeats its last reading
    VALVES_IGNORED = 11  # the valves hold their pressure, whatever the commands; status says running
    PROTOCOL_CHANGE = 12  # announce protocol `value` (default: its own + 1) and go on
    SEQUENCE_STUCK = 13  # every sample carries the same sequence number
    CAN_ERROR_FRAMES = 14  # CAN error frames beside the traffic, `value` per second (default 100)
    BUS_OFF = 15  # the CAN controller reports bus-off, then nothing crosses either way
    CLOCK_DRIFT = 16  # the board's clock runs fast by `value` ppm (signed 16-bit: above 32767 is slow)
    SENSOR_NAN = 17  # the finger's flex sensor reads NaN (serial-v1 only: can-v1 cannot carry it)
    SENSOR_DRIFT = 18  # the finger's flex sensor drifts by `value` mV/s (signed 16-bit) from the request on


FAULT_VALUE_MODULO = 1 << 16  # `value` is 16 bits on the wire


def signed_value(value: int) -> int:
    """A fault request's 16-bit `value` read as signed (CLOCK_DRIFT: a slow clock is negative)."""
    value %= FAULT_VALUE_MODULO
    return value - FAULT_VALUE_MODULO if value >= FAULT_VALUE_MODULO // 2 else value


@dataclass
class SensorReport:
    """Firmware -> host at the sample rate: every finger's flex sensor and chamber pressure."""

    sequence: int
    command_sequence: int  # the newest valid valve command the firmware held at sampling
    sensor_mv: list[float]
    pressure_meas_kpa: list[float]


@dataclass
class ValveCommand:
    """Host -> firmware: chamber-pressure setpoints for every finger."""

    sequence: int
    pressure_cmd_kpa: list[float]


@dataclass
class Status:
    """Firmware -> host heartbeat (10 Hz, and at once on a change of state)."""

    state: FirmwareState
    uptime_ms: int
    fault_active: FaultKind = FaultKind.CLEAR  # the debug port's injection, not a fault of the board
    rx_errors: int = 0  # bad frames the firmware received (saturates at 255)
    fault_code: FirmwareFault | int = FirmwareFault.NONE  # the board's own fault (firmware_fault())


@dataclass
class VersionInfo:
    """Firmware -> host: at boot, and in answer to a VersionRequest."""

    protocol_version: int
    firmware_version: tuple[int, int, int]
    finger_count: int

    @property
    def firmware_text(self) -> str:
        return ".".join(str(v) for v in self.firmware_version)


@dataclass
class VersionRequest:
    """Host -> firmware: the handshake; the firmware answers with VersionInfo."""

    protocol_version: int


@dataclass
class FaultRequest:
    """Host -> firmware debug port: inject a fault (see FaultKind)."""

    kind: FaultKind
    finger_index: int = ALL_FINGERS
    duration_ms: int = 0  # 0: until cleared (REBOOT: ignored)
    value: int = 0


Message = SensorReport | ValveCommand | Status | VersionInfo | VersionRequest | FaultRequest


@dataclass
class DecodeStats:
    """What a decoder threw away, by reason. Counters only grow."""

    frames: int = 0  # frames that arrived intact
    crc_errors: int = 0
    decode_errors: int = 0
    incomplete: int = 0  # a multi-frame message that never completed
    garbage_bytes: int = 0
    frame_gaps: int = 0  # link-level frames lost (serial: frame sequence)
    ignored: int = 0  # frames for other nodes (a CAN bus is shared)
    errors: list[str] = field(default_factory=list)  # the newest reasons, for the log

    def note(self, text: str) -> None:
        self.errors.append(text)
        del self.errors[:-8]


def sequence_delta(new: int, old: int) -> int:
    """How far `new` is ahead of `old` on the wrapping 8-bit counter (0..255)."""
    return (new - old) % SEQUENCE_MODULO
