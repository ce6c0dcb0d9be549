"""Deliberately broken variants of the mock firmware: each breaks one rule of the protocol,
so that `hand-service board-check` can be shown to catch it (tests/boardcheck/).

    NoWatchdogFirmware      never vents when the commands stop
    WrongCrcFirmware        sends serial-v1 frames with CRC-16/XMODEM (init 0, not 0xFFFF),
                            can-v1 frames with their E2E CRC byte inverted
    StuckSequenceFirmware   every sample carries the same sequence number
    EchoVersionFirmware     answers a VersionRequest with the protocol the host asked for
    SilentRebootFirmware    does not announce itself (VersionInfo) when it boots
    QuietIdleFirmware       sends no samples until it is commanded, and none once vented
    CountsRubbishFirmware   counts rubbish bytes in rx_errors beside the bad frames
    ZeroVentsFirmware       takes a command of 0 kPa on every finger for a vent request and
                            leaves running for watchdog_vented (0 kPa is a valid setpoint)

None of them is reachable from the command line: they exist for the tests.
"""

from __future__ import annotations

import binascii
import math
from typing import Any

import can

from hand_service.firmware.mock import MockFirmware
from hand_service.wire.framing import CRC_BYTES
from hand_service.wire.messages import (
    FirmwareState,
    Message,
    SensorReport,
    ValveCommand,
    VersionInfo,
    VersionRequest,
)


class NoWatchdogFirmware(MockFirmware):
    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.watchdog_s = math.inf


def _wrong_crc(unit: Any) -> Any:
    if isinstance(unit, can.Message):
        data = bytearray(unit.data)
        data[0] ^= 0xFF
        return can.Message(arbitration_id=unit.arbitration_id, is_extended_id=unit.is_extended_id, data=data)
    body = unit[2:-CRC_BYTES]
    return unit[:-CRC_BYTES] + binascii.crc_hqx(body, 0x0000).to_bytes(CRC_BYTES, "little")


class _WrongCrcCodec:
    """The mock's codec, but every frame it encodes carries a wrong CRC."""

    def __init__(self, codec: Any) -> None:
        self._codec = codec

    def __getattr__(self, name: str) -> Any:
        return getattr(self._codec, name)

    def encode(self, message: Message) -> list[Any]:
        return [_wrong_crc(unit) for unit in self._codec.encode(message)]


class WrongCrcFirmware(MockFirmware):
    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.codec = _WrongCrcCodec(self.codec)  # type: ignore[assignment]


class StuckSequenceFirmware(MockFirmware):
    def _sample(self, now: float) -> None:
        sequence = self.sequence
        super()._sample(now)
        self.sequence = sequence


class EchoVersionFirmware(MockFirmware):
    def _handle(self, message: Message, now: float) -> None:
        if isinstance(message, VersionRequest) and self.state != FirmwareState.BOOTING:
            self._status(now)
            self._send(VersionInfo(message.protocol_version, self.firmware_version, self.n), now)
            return
        super()._handle(message, now)


class SilentRebootFirmware(MockFirmware):
    _booting = False

    def _announce(self, now: float) -> None:
        self._booting = True
        try:
            super()._announce(now)
        finally:
            self._booting = False

    def _send(self, message: Message, now: float) -> None:
        if not (self._booting and isinstance(message, VersionInfo)):
            super()._send(message, now)


class QuietIdleFirmware(MockFirmware):
    def _send(self, message: Message, now: float) -> None:
        if not (isinstance(message, SensorReport) and self.state != FirmwareState.RUNNING):
            super()._send(message, now)


class CountsRubbishFirmware(MockFirmware):
    def _status(self, now: float) -> None:
        stats = self.codec.stats
        garbage = stats.garbage_bytes + stats.ignored  # serial rubbish bytes; CAN frames of other ids
        stats.decode_errors += garbage - getattr(self, "_garbage_counted", 0)
        self._garbage_counted = garbage
        super()._status(now)


class ZeroVentsFirmware(MockFirmware):
    def _handle(self, message: Message, now: float) -> None:
        if not (isinstance(message, ValveCommand) and self.state in (FirmwareState.RUNNING,
                                                                     FirmwareState.WATCHDOG_VENTED)
                and not any(message.pressure_cmd_kpa)):
            super()._handle(message, now)
            return
        self.command_kpa[:] = message.pressure_cmd_kpa  # acknowledged and vented, but not running
        self.command_sequence = message.sequence
        self.last_command_s = now
        self.state = FirmwareState.WATCHDOG_VENTED


VARIANTS: dict[str, type[MockFirmware]] = {
    "no-watchdog": NoWatchdogFirmware, "wrong-crc": WrongCrcFirmware,
    "stuck-sequence": StuckSequenceFirmware, "echo-version": EchoVersionFirmware,
    "silent-reboot": SilentRebootFirmware, "quiet-idle": QuietIdleFirmware,
    "counts-rubbish": CountsRubbishFirmware, "zero-vents": ZeroVentsFirmware,
}
