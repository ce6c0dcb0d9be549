"""The C can-v1 codec (csrc/rtcore_can.c) against the Python one (can_codec.py), frame for frame:
the same frames for every message with random values (or both refuse it), the same messages
and the same counters for any stream of frames (intact, CRC errors, wrong lengths, wrong
counters, unknown ids, values out of range), the same E2E CRC as cantools."""

from __future__ import annotations

import math
from pathlib import Path

import can
import pytest
from cantools.autosar.end_to_end import compute_profile2_crc
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hand_service.config.profile import load_profile
from hand_service.wire.can_c_codec import CCanCodec, builtin_layout
from hand_service.wire.can_codec import CanCodec
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
)
from rtcore.can import e2e_crc

DBC = load_profile("can-v1.yaml").transport["dbc"]
N_FINGERS = 5
IDS = (0x110, 0x120, 0x130, 0x140, 0x141, 0x7E0)
SETTINGS = settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])


_CODECS = {n: (CanCodec(DBC, n), CCanCodec(DBC, n)) for n in range(1, 9)}  # a DBC loads in ms: once
SOURCE = _CODECS[8][0]  # encodes the frames streams are made of


def pair(n_fingers: int = N_FINGERS) -> tuple[CanCodec, CCanCodec]:
    """Both codecs for n_fingers, as new: counters at 0, nothing being reassembled."""
    py, c = _CODECS[n_fingers]
    py.stats, py._partial = DecodeStats(), {"SensorFinger": None, "ValveCommand": None}
    c.stats, c._synced = DecodeStats(), (0, 0, 0, 0, 0)
    c.core.init()
    return py, c


def frames_of(codec: CanCodec | CCanCodec, message: Message) -> list[tuple[int, bytes]] | str:
    try:
        return [(f.arbitration_id, bytes(f.data)) for f in codec.encode(message)]
    except Exception:  # the Python codec refuses with ValueError or cantools' EncodeError
        return "refused"


def same(a: Message, b: Message) -> bool:
    """Equal, NaN equal to NaN."""
    if type(a) is not type(b):
        return False
    for x, y in zip(vars(a).values(), vars(b).values(), strict=True):
        if isinstance(x, list):
            if len(x) != len(y) or any(not (u == v or (math.isnan(u) and math.isnan(v)))
                                       for u, v in zip(x, y, strict=True)):
                return False
        elif x != y:
            return False
    return True


def counters(codec: CanCodec | CCanCodec) -> tuple[int, ...]:
    s = codec.stats
    return s.frames, s.crc_errors, s.decode_errors, s.ignored, s.incomplete


floats = st.floats(allow_nan=True, allow_infinity=True, width=64)
near = st.one_of(floats, st.floats(-700.0, 700.0), st.floats(-10.0, 7000.0),
                 st.sampled_from([-655.36, -655.34, 655.34, 655.36, 0.01, -0.01, 0.03, 6553.5, 6553.55]))
ints = st.one_of(st.integers(-5, 300), st.integers(-(2**40), 2**40), st.integers(60000, 70000))
fingers = st.integers(1, 8)


@st.composite
def messages(draw: st.DrawFn) -> Message:
    kind = draw(st.sampled_from(["sensor", "valve", "status", "version", "request", "fault"]))
    n = draw(fingers)
    if kind == "sensor":
        return SensorReport(draw(ints), draw(ints), draw(st.lists(near, min_size=n, max_size=n)),
                            draw(st.lists(near, min_size=n, max_size=n)))
    if kind == "valve":
        return ValveCommand(draw(ints), draw(st.lists(near, min_size=n, max_size=n)))
    if kind == "status":
        return Status(draw(st.sampled_from(list(FirmwareState))), draw(ints),
                      draw(st.sampled_from(list(FaultKind))), draw(ints), draw(st.integers(-1, 300)))
    if kind == "version":
        return VersionInfo(draw(ints), (draw(ints), draw(ints), draw(ints)), draw(st.integers(-1, 10)))
    if kind == "request":
        return VersionRequest(draw(ints))
    return FaultRequest(draw(st.sampled_from(list(FaultKind))), draw(ints), draw(ints), draw(ints))


@SETTINGS
@given(messages())
def test_every_message_encodes_to_the_same_frames_or_is_refused_by_both(message: Message) -> None:
    py, c = pair()
    assert frames_of(c, message) == frames_of(py, message)


@st.composite
def frames(draw: st.DrawFn) -> can.Message:
    """A frame as a bus may deliver it: an intact one of a random message, or one broken."""
    how = draw(st.sampled_from(["intact", "intact", "intact", "flip", "length", "raw", "id", "error"]))
    if how in ("intact", "flip", "length"):
        encoded = SOURCE.encode(draw(messages().filter(lambda m: frames_of(SOURCE, m) != "refused")))
        frame = draw(st.sampled_from(encoded))
        data = bytearray(frame.data)
        if how == "flip":  # a CRC error, or (byte 0) a wrong CRC
            data[draw(st.integers(0, len(data) - 1))] ^= 1 << draw(st.integers(0, 7))
        elif how == "length":
            data = data[:-1] if draw(st.booleans()) else data + b"\0"
        return can.Message(arbitration_id=frame.arbitration_id, data=bytes(data), is_extended_id=False)
    if how == "raw":  # any bytes under a known id, the CRC right: out-of-range fields, wrong indices
        frame_id = draw(st.sampled_from(IDS))
        data = bytearray(draw(st.binary(min_size=8, max_size=8)))
        length = {0x110: 8, 0x120: 6, 0x130: 8, 0x140: 8, 0x141: 4, 0x7E0: 8}[frame_id]
        data = data[:length]
        data[0] = compute_profile2_crc(bytes(data), frame_id & 0xFF)
        return can.Message(arbitration_id=frame_id, data=bytes(data), is_extended_id=False)
    if how == "id":
        return can.Message(arbitration_id=draw(st.integers(0, 0x7FF).filter(lambda i: i not in IDS)),
                           data=draw(st.binary(max_size=8)), is_extended_id=False)
    return can.Message(arbitration_id=draw(st.sampled_from(IDS)), is_error_frame=True, data=b"")


@SETTINGS
@given(st.lists(frames(), max_size=40), st.integers(1, 8))
def test_any_stream_of_frames_decodes_to_the_same_messages_and_counters(
        stream: list[can.Message], n_fingers: int) -> None:
    py, c = pair(n_fingers)
    for frame in stream:
        got_py, got_c = py.decode(frame), c.decode(frame)
        assert len(got_c) == len(got_py)
        assert all(same(a, b) for a, b in zip(got_c, got_py, strict=True)), (got_c, got_py)
        assert counters(c) == counters(py)


@SETTINGS
@given(st.lists(st.tuples(st.integers(0, 7), st.integers(0, 255)), min_size=1, max_size=60))
def test_fingers_out_of_order_and_interleaved_sequences_reassemble_alike(
        order: list[tuple[int, int]]) -> None:
    """Sensor frames of several sequences, fingers in any order: the same complete samples
    and the same count of abandoned ones."""
    py, c = pair(4)
    for finger, sequence in order:
        report = SensorReport(sequence, sequence + 1, [float(finger)] * 8, [math.nan] * 8)
        frame = SOURCE.encode(report)[finger]
        got_py, got_c = py.decode(frame), c.decode(frame)
        assert len(got_py) == len(got_c) and all(same(a, b) for a, b in zip(got_c, got_py, strict=True))
        assert counters(c) == counters(py)


@SETTINGS
@given(st.binary(min_size=2, max_size=8), st.integers(0, 255))
def test_the_e2e_crc_is_cantools_profile_2(data: bytes, data_id: int) -> None:
    assert e2e_crc(data, data_id) == compute_profile2_crc(data, data_id)


def test_nan_pressure_crosses_as_not_reported_and_nan_flex_is_refused_by_both() -> None:
    py, c = pair(2)
    report = SensorReport(1, 2, [100.0, 200.0], [math.nan, 5.0])
    assert frames_of(c, report) == frames_of(py, report) != "refused"
    decoded = [m for f in c.encode(report) for m in c.decode(f)]
    assert math.isnan(decoded[0].pressure_meas_kpa[0]) and decoded[0].pressure_meas_kpa[1] == 5.0
    bad = SensorReport(1, 2, [math.nan, 200.0], [1.0, 5.0])
    assert frames_of(c, bad) == frames_of(py, bad) == "refused"


def test_a_command_beyond_the_wire_or_nan_is_refused_not_clipped() -> None:
    py, c = pair(2)
    for kpa in (math.nan, math.inf, 655.36, -655.38):
        with pytest.raises(ValueError):
            c.encode(ValveCommand(1, [0.0, kpa]))
        assert frames_of(py, ValveCommand(1, [0.0, kpa])) == "refused"


def test_the_c_codec_speaks_only_the_dbc_it_was_generated_from(tmp_path: Path) -> None:
    assert builtin_layout(DBC)
    moved = tmp_path / "lab.dbc"
    moved.write_text(Path(DBC).read_text().replace("pressure_cmd_kpa : 32|16@1- (0.02,0)",
                                                   "pressure_cmd_kpa : 32|16@1- (0.01,0)"))
    assert not builtin_layout(moved)
    with pytest.raises(ValueError, match="layout"):
        CCanCodec(moved, N_FINGERS)
    commented = tmp_path / "commented.dbc"  # a comment changes nothing the C depends on
    commented.write_text(Path(DBC).read_text().replace('"Heartbeat at 10 Hz', '"A heartbeat at 10 Hz'))
    assert builtin_layout(commented)
