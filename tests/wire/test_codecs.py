"""Both codecs carry every message both ways; counters wrap; the serial layouts match the docs."""

from __future__ import annotations

import re

import pytest

from hand_service.profile import ROOT, load_profile
from hand_service.wire.can_codec import CanCodec
from hand_service.wire.messages import (
    FaultKind,
    FaultRequest,
    FirmwareState,
    SensorReport,
    Status,
    ValveCommand,
    VersionInfo,
    VersionRequest,
)
from hand_service.wire.serial_codec import LAYOUTS, SerialCodec

MESSAGES = [
    SensorReport(300, 257, [500.0, 512.5, 0.0, 4999.5, 1.0], [10.0, 20.0, 0.0, -5.0, 100.0]),
    ValveCommand(1000, [1.0, 2.0, 3.0, 4.0, 5.5]),
    Status(FirmwareState.WATCHDOG_VENTED, 12345, FaultKind.STUCK_SENSOR, 3),
    VersionInfo(1, (1, 2, 3), 5),
    VersionRequest(1),
    FaultRequest(FaultKind.DROP, 255, 500, 30),
]


def _codecs() -> list[CanCodec | SerialCodec]:
    dbc = load_profile("can-v1.yaml").transport["dbc"]
    return [CanCodec(dbc, 5), SerialCodec(5)]


@pytest.mark.parametrize("codec", _codecs(), ids=["can", "serial"])
@pytest.mark.parametrize("message", MESSAGES, ids=lambda m: type(m).__name__)
def test_round_trip(codec: CanCodec | SerialCodec, message: object) -> None:
    decoded = [m for unit in codec.encode(message) for m in codec.decode(unit)]  # type: ignore[arg-type]
    assert len(decoded) == 1
    got = decoded[0]
    if isinstance(message, SensorReport | ValveCommand):  # 8-bit counters on the wire
        assert got.sequence == message.sequence % 256
    if isinstance(message, SensorReport):
        assert got.command_sequence == message.command_sequence % 256
        assert got.sensor_mv == pytest.approx(message.sensor_mv, abs=0.05)
        assert got.pressure_meas_kpa == pytest.approx(message.pressure_meas_kpa, abs=0.01)
    elif isinstance(message, ValveCommand):
        assert got.pressure_cmd_kpa == pytest.approx(message.pressure_cmd_kpa, abs=0.01)
    else:
        assert got == message
    assert codec.stats.crc_errors == codec.stats.decode_errors == 0


def test_can_sensor_readings_saturate_at_the_signal_range() -> None:
    codec = _codecs()[0]
    report = SensorReport(1, 0, [70000.0, -3.0, 1.0, 1.0, 1.0], [900.0, 0.0, 0.0, 0.0, 0.0])
    (got,) = [m for f in codec.encode(report) for m in codec.decode(f)]
    assert got.sensor_mv[:2] == [pytest.approx(6553.5), 0.0]
    assert got.pressure_meas_kpa[0] == pytest.approx(655.34)


def test_serial_layouts_are_the_documented_ones() -> None:
    doc = (ROOT / "docs" / "serial-protocol.md").read_text()
    for cls, layout in LAYOUTS.items():
        assert re.search(rf"\| 0x{layout.type:02X} \| {cls.__name__} \|", doc), cls.__name__
