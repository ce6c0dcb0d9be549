"""Recordings: docs/formats.md's CSV, every kind of bad input a clear error."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hand_service.errors import UserError
from hand_service.recording import read_recording, write_recording


def good(tmp_path: Path, n: int = 300, rate: float = 100.0, **extra: np.ndarray) -> Path:
    t = np.arange(n) / rate
    path = tmp_path / "rec.csv"
    write_recording(path, {"t": t, "pressure_kpa": 10 * np.sin(t), "angle_deg": 20 * np.sin(t), **extra},
                    {"finger": "index", "sample_rate_hz": rate})
    return path


def test_round_trip_with_metadata_and_extra_columns(tmp_path: Path) -> None:
    path = good(tmp_path, force_n=np.ones(300))
    rec = read_recording(path)
    assert rec.sample_rate_hz == pytest.approx(100.0)
    assert rec.metadata["finger"] == "index"
    assert rec.optional("force_n") is not None and rec.optional("nothing") is None
    assert rec.angle_deg[100] == pytest.approx(20 * np.sin(1.0), rel=1e-5)


def test_multi_finger_columns_need_and_accept_a_finger(tmp_path: Path) -> None:
    t = np.arange(200) / 100.0
    path = tmp_path / "hand.csv"
    write_recording(path, {"t": t, "pressure_kpa_index": t, "angle_deg_index": 2 * t,
                           "pressure_kpa_thumb": 3 * t, "angle_deg_thumb": 4 * t,
                           "mode_index": ["position"] * 200})
    with pytest.raises(UserError, match="several fingers"):
        read_recording(path)
    rec = read_recording(path, finger="thumb")
    np.testing.assert_allclose(rec.angle_deg, 4 * t, rtol=1e-5)
    assert read_recording(path, finger="index").text_columns["mode"][0] == "position"
    with pytest.raises(UserError, match="no columns for finger 'ring'"):
        read_recording(path, finger="ring")
    shared = tmp_path / "shared.csv"  # a finger's own column before the one the fingers share
    write_recording(shared, {"t": t, "pressure_kpa": 5 * t, "pressure_kpa_index": t,
                             "angle_deg_index": 2 * t, "angle_deg_thumb": 4 * t})
    np.testing.assert_allclose(read_recording(shared, finger="index").pressure_kpa, t, rtol=1e-5)
    np.testing.assert_allclose(read_recording(shared, finger="thumb").pressure_kpa, 5 * t, rtol=1e-5)


@pytest.mark.parametrize(("mutate", "message"), [
    (lambda s: s.replace("angle_deg", "angle"), "missing required column 'angle_deg'"),
    (lambda s: s.replace("\n0.5,", "\nabc,", 1), r"rec.csv:\d+: column 't': not a number"),
    (lambda s: s.replace("\n0.5,", "\n0.5,1,2,", 1), r"rec.csv:\d+: 5 fields where the header has 3"),
    (lambda s: s.replace("\n1,", "\n0.1,", 1), "does not increase"),
    # finite, yet past any reading: a corrupt or mis-scaled file (they overflowed the fits)
    (lambda s: s.replace("\n0.06,0.59964,", "\n0.06,1e300,", 1),
     r"rec.csv:\d+: column 'pressure_kpa': 1e\+300 kPa is past any pressure"),
    (lambda s: s.replace("\n0.06,0.59964,1.19928", "\n0.06,0.59964,-2e6", 1),
     r"rec.csv:\d+: column 'angle_deg': -2e\+06 deg"),
    (lambda s: s.rstrip("\n").rsplit("\n", 1)[0] + "\n1e300,0,0\n",
     r"rec.csv:\d+: column 't': 1e\+300 s is past"),
    (lambda s: s.replace("t,pressure_kpa,angle_deg", "angle_deg,pressure_kpa,angle_deg", 1),
     r"rec.csv:1: column 'angle_deg' appears twice in the header \(fields 1 and 3\)"),
])
def test_bad_input_is_named(tmp_path: Path, mutate, message: str) -> None:
    path = good(tmp_path)
    path.write_text(mutate(path.read_text()))
    with pytest.raises(UserError, match=message):
        read_recording(path)


def test_nan_in_a_required_column(tmp_path: Path) -> None:
    path = good(tmp_path)
    lines = path.read_text().splitlines()
    fields = lines[10].split(",")
    fields[2] = "nan"
    lines[10] = ",".join(fields)
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(UserError, match=r"rec.csv:11: column 'angle_deg': NaN"):
        read_recording(path)


def test_too_short(tmp_path: Path) -> None:
    with pytest.raises(UserError, match="at least 1 s"):
        read_recording(good(tmp_path, n=50))


def test_truncated_last_line_is_dropped(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    path = good(tmp_path)
    text = path.read_text()
    path.write_text(text + "3.00,1.2")  # a writer killed mid-line
    rec = read_recording(path)
    assert len(rec) == 300
    assert "truncated" in caplog.text


def test_500_hz_with_jitter(tmp_path: Path) -> None:
    t = np.arange(1000) / 500.0 + np.random.default_rng(0).uniform(-1e-4, 1e-4, 1000)
    path = tmp_path / "fast.csv"
    write_recording(path, {"t": t, "pressure_kpa": np.zeros(1000), "angle_deg": np.zeros(1000)})
    assert read_recording(path).sample_rate_hz == pytest.approx(500.0, rel=1e-3)


def test_a_header_alone_utf16_without_its_mark_and_a_short_pairs_file(tmp_path: Path) -> None:
    """Messages that said something else (an outside probe): a header with no rows was "only
    0 s of data", UTF-16 without a byte-order mark "missing required column 't'", and a
    pairs file (which needs no duration) of one row "at least 0 s is needed"."""
    path = tmp_path / "rec.csv"
    path.write_text("t,pressure_kpa,angle_deg\n# finger: index\n")
    with pytest.raises(UserError, match=r"rec.csv:1: a header and no data rows after it"):
        read_recording(path)
    path.write_bytes("t,pressure_kpa,angle_deg\n0,1,2\n".encode("utf-16-le"))
    with pytest.raises(UserError, match=r"rec.csv:1: a NUL byte in the text \(UTF-16 without"):
        read_recording(path)
    path.write_text("sensor_mv,angle_deg\n1.0,20.0\n")
    pairs = read_recording(path, required=("sensor_mv", "angle_deg"), min_duration_s=0.0)
    assert pairs.columns["angle_deg"].tolist() == [20.0]


def test_a_typo_in_a_measured_column_is_an_error_not_text(tmp_path: Path) -> None:
    """pressure_meas_kpa with 'abc' in one cell became a text column, and calibrate gain fell
    back to the command without a word (an outside probe): a column whose name carries a
    unit is a measured quantity (docs/formats.md), as export already held it."""
    path = good(tmp_path, pressure_meas_kpa=np.full(300, 5.0), mode=np.array(["position"] * 300))
    lines = path.read_text().splitlines()
    lines[10] = lines[10].replace(",5,", ",abc,")
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(UserError, match=r"rec.csv:11: column 'pressure_meas_kpa': not a number: 'abc'"):
        read_recording(path)
    lines[10] = lines[10].replace(",abc,", ",nan,").replace("position", "force")  # NaN: a number; text stays
    path.write_text("\n".join(lines) + "\n")
    recording = read_recording(path)
    (row,) = np.flatnonzero(np.isnan(recording.columns["pressure_meas_kpa"]))
    assert recording.text_columns["mode"][row] == "force"
