"""Both codecs carry every message both ways; counters wrap; the serial layouts match the docs."""

from __future__ import annotations

import math
import re

import pytest

from hand_service.config.profile import ROOT, load_profile
from hand_service.wire.can_codec import CanCodec
from hand_service.wire.messages import (
    FaultKind,
    FaultRequest,
    FirmwareFault,
    FirmwareState,
    SensorReport,
    Status,
    ValveCommand,
    VersionInfo,
    VersionRequest,
)
from hand_service.wire.serial_codec import F32_MAX, LAYOUTS, SerialCodec

MESSAGES = [
    SensorReport(300, 257, [500.0, 512.5, 0.0, 4999.5, 1.0], [10.0, 20.0, 0.0, -5.0, 100.0]),
    ValveCommand(1000, [1.0, 2.0, 3.0, 4.0, 5.5]),
    Status(FirmwareState.WATCHDOG_VENTED, 12345, FaultKind.STUCK_SENSOR, 3),
    Status(FirmwareState.FAULT, 99, FaultKind.DROP, 0, FirmwareFault.OVER_PRESSURE),  # two faults apart
    Status(FirmwareState.FAULT, 7, FaultKind.CLEAR, 0, 200),  # a fault this host does not know
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
    codes = {"u8": "B", "u16": "H", "u32": "I", "f32": "f"}
    for cls, layout in LAYOUTS.items():
        row = re.search(rf"\| 0x{layout.type:02X} \| {cls.__name__} \|[^|]*\| (.*) \|", doc)
        assert row, cls.__name__
        head, _, per_finger = row.group(1).partition("then n")
        documented = "<" + "".join(codes[t] for t in re.findall(r"\b([uf]\d+) ", head))
        assert documented == layout.header.format, cls.__name__
        if layout.per_finger is not None:
            each = "<" + "".join(codes[t] for t in re.findall(r"\b([uf]\d+) ", per_finger))
            assert each == layout.per_finger.format, cls.__name__


def _round_trip(codec: CanCodec | SerialCodec, message: object) -> object:
    (got,) = [m for unit in codec.encode(message) for m in codec.decode(unit)]  # type: ignore[arg-type]
    return got


@pytest.mark.parametrize("codec", _codecs(), ids=["can", "serial"])
def test_a_pressure_not_reported_crosses_as_nan(codec: CanCodec | SerialCodec) -> None:
    """A board without pressure sensing: NaN on the host, never 0 kPa measured."""
    report = SensorReport(3, 1, [500.0] * 5, [math.nan, 0.0, math.nan, -12.5, 100.0])
    got = _round_trip(codec, report)
    assert isinstance(got, SensorReport)
    assert math.isnan(got.pressure_meas_kpa[0]) and math.isnan(got.pressure_meas_kpa[2])
    assert got.pressure_meas_kpa[1:2] + got.pressure_meas_kpa[3:] == pytest.approx([0.0, -12.5, 100.0])


def test_can_pressure_limits_cross_and_never_hit_the_sentinel() -> None:
    codec = _codecs()[0]
    low, high = codec.signal_range("SensorFinger", "pressure_meas_kpa")
    assert (low, high) == pytest.approx((-655.34, 655.34))
    report = SensorReport(4, 0, [1.0] * 5, [low, high, -1e9, -math.inf, math.inf])
    got = _round_trip(codec, report)
    assert isinstance(got, SensorReport)
    # off the scale is the scale's end: the lowest reading is not the not_reported raw value
    assert got.pressure_meas_kpa == pytest.approx([low, high, low, low, high])


@pytest.mark.parametrize("codec", _codecs(), ids=["can", "serial"])
def test_command_limits_cross_exactly(codec: CanCodec | SerialCodec) -> None:
    low, high = codec.command_range_kpa()
    got = _round_trip(codec, ValveCommand(1, [low, high, 0.0, 999.0 if high > 1e3 else 1.0, -0.02]))
    assert isinstance(got, ValveCommand)
    assert got.pressure_cmd_kpa == pytest.approx([low, high, 0.0, 999.0 if high > 1e3 else 1.0, -0.02],
                                                 rel=1e-6, abs=1e-9)


@pytest.mark.parametrize("codec", _codecs(), ids=["can", "serial"])
def test_a_command_the_wire_cannot_carry_is_refused_not_clipped(codec: CanCodec | SerialCodec) -> None:
    low, high = codec.command_range_kpa()
    for bad in (math.nan, math.inf, -math.inf, high * 1.01 + 1.0, low * 1.01 - 1.0):
        with pytest.raises(ValueError, match="pressure command"):
            codec.encode(ValveCommand(1, [bad, 0.0, 0.0, 0.0, 0.0]))


def test_can_commands_span_what_the_dbc_declares() -> None:
    assert _codecs()[0].command_range_kpa() == pytest.approx((-655.36, 655.34))
    assert SerialCodec.command_range_kpa() == (-F32_MAX, F32_MAX)


def test_a_lab_dbc_with_value_tables_on_any_signal_still_decodes(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """Value tables are a lab's to add (names for finger indices, say): decoding stays
    numeric, and only the reading's not_reported value means no reading."""
    dbc = ROOT / "firmware_profiles" / "can-v1.dbc"
    text = dbc.read_text() + 'VAL_ 272 finger_index 0 "thumb" 1 "index" ;\nVAL_ 272 sequence 3 "three" ;\n'
    lab = tmp_path / "lab.dbc"
    lab.write_text(text)
    codec = CanCodec(lab, 5)
    report = SensorReport(3, 1, [500.0, 501.0, 502.0, 503.0, 504.0], [math.nan, 1.0, 2.0, 3.0, 4.0])
    got = _round_trip(codec, report)
    assert isinstance(got, SensorReport) and got.sequence == 3
    assert got.sensor_mv == pytest.approx(report.sensor_mv)
    assert math.isnan(got.pressure_meas_kpa[0])
    assert got.pressure_meas_kpa[1:] == pytest.approx([1.0, 2.0, 3.0, 4.0])
