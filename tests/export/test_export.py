"""`hand-service export`: a daemon recording to .mat, Parquet and MCAP, read back with
scipy, pyarrow and the mcap reader; every column, value, unit and metadata line equal to
the CSV's."""

from __future__ import annotations

import csv
import json
import math
import sys
from pathlib import Path

import mcap.reader
import numpy as np
import pandas as pd
import pyarrow.parquet as pq
import pytest
from scipy.io import loadmat

from hand_service.cli import main
from hand_service.export.mcap_log import start_ns
from hand_service.recording import write_recording
from tests.export.daemon_recording import DAEMON_UNITS, record_daemon

FINGERS = ("thumb", "index", "middle", "ring", "little")


def read_csv(path: Path) -> tuple[list[str], dict[str, list[str]], dict[str, str]]:
    """The CSV read independently of the project: header, cells by column, `# k: v` lines."""
    header: list[str] = []
    rows: list[list[str]] = []
    metadata: dict[str, str] = {}
    with open(path, newline="") as f:
        for row in csv.reader(f):
            if row and row[0].startswith("#"):
                key, _, value = ",".join(row)[1:].partition(":")
                metadata[key.strip()] = value.strip()
            elif not header:
                header = row
            elif row:
                rows.append(row)
    return header, {name: [r[i] for r in rows] for i, name in enumerate(header)}, metadata


def expected_unit(column: str) -> str:
    if column == "t":
        return "s"
    if column == "state":
        return ""
    quantity, finger = column.rsplit("_", 1)
    assert finger in FINGERS, column
    return DAEMON_UNITS[quantity]


def assert_same_column(name: str, cells: list[str], values: object) -> None:
    """Text cells equal as text; numbers equal to the CSV's (NaN where the CSV has nan)."""
    if name == "state" or name.startswith("mode_"):
        assert [str(v) for v in values] == cells, name  # type: ignore[union-attr]
        return
    expected = np.array([float(c) for c in cells])
    got = np.array([np.nan if v is None else v for v in values], dtype=float)  # type: ignore[union-attr]
    np.testing.assert_array_equal(got, expected, err_msg=name)


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return record_daemon(tmp_path_factory.mktemp("export_daemon"))


@pytest.fixture(scope="module")
def csv_file(recording: Path) -> tuple[list[str], dict[str, list[str]], dict[str, str]]:
    header, cells, metadata = read_csv(recording)
    assert len(header) == 2 + 11 * len(FINGERS)  # t, state, 11 quantities a finger
    assert {"RUNNING", "DISARMED"} <= set(cells["state"])
    assert "position" in cells["mode_index"] and "force" in cells["mode_thumb"]
    assert "nan" in cells["force_ref_n_index"]
    assert {"profile", "fingers", "started", "software_version"} <= set(metadata)
    return header, cells, metadata


def export(recording: Path, to: str, out: Path) -> Path:
    assert main(["export", str(recording), "--to", to, "-o", str(out)]) == 0
    return out


def test_mat_round_trip(recording: Path, csv_file, tmp_path: Path) -> None:
    header, cells, metadata = csv_file
    mat = loadmat(export(recording, "mat", tmp_path / "run.mat"), squeeze_me=True, chars_as_strings=True)
    assert [str(c) for c in mat["columns"]] == header
    units = mat["units"]
    for name in header:
        assert_same_column(name, cells[name], list(mat[name]))
        assert mat_text(units[name].item()) == expected_unit(name), name
    for key, value in metadata.items():
        assert mat_text(mat["metadata"][key].item()) == value


def mat_text(value: object) -> str:
    """A char array read back by loadmat: MATLAB's '' comes back as an empty array."""
    return "" if np.size(value) == 0 else str(value)


def test_parquet_round_trip(recording: Path, csv_file, tmp_path: Path) -> None:
    header, cells, metadata = csv_file
    table = pq.read_table(export(recording, "parquet", tmp_path / "run.parquet"))
    assert table.column_names == header
    for name in header:
        field = table.schema.field(name)
        assert field.metadata[b"unit"].decode() == expected_unit(name), name
        assert_same_column(name, cells[name], table.column(name).to_pylist())
    assert str(table.schema.field("flags_index").type) == "int64"
    assert json.loads(table.schema.metadata[b"hand_service.metadata"]) == metadata


def test_mcap_round_trip(recording: Path, csv_file, tmp_path: Path) -> None:
    header, cells, metadata = csv_file
    with open(export(recording, "mcap", tmp_path / "run.mcap"), "rb") as f:
        reader = mcap.reader.make_reader(f)
        got: dict[str, list[object]] = {}
        units: dict[str, str] = {}
        times: dict[str, list[int]] = {}
        for schema, channel, message in reader.iter_messages():
            assert schema.encoding == "jsonschema" and channel.message_encoding == "json"
            properties = json.loads(schema.data)["properties"]
            columns = json.loads(channel.metadata["columns"])
            channel_units = json.loads(channel.metadata["units"])
            data = json.loads(message.data)
            assert set(data) == set(properties) == set(columns)
            times.setdefault(channel.topic, []).append(message.log_time)
            for key, value in data.items():
                column = columns[key]
                if key == "t" and channel.topic != "/hand":
                    continue  # each finger's message repeats t
                got.setdefault(column, []).append(value)
                units[column] = channel_units[key]
                assert properties[key]["unit"] == channel_units[key]
        records = list(reader.iter_metadata())
    assert set(times) == {"/hand", *(f"/hand/{f}" for f in FINGERS)}
    assert sorted(got) == sorted(header)
    for name in header:
        assert_same_column(name, cells[name], got[name])
        assert units[name] == expected_unit(name), name
    t0 = start_ns(metadata)
    assert t0 > 0
    for topic_times in times.values():
        assert topic_times == [t0 + round(float(t) * 1e9) for t in cells["t"]]
    assert [r.name for r in records] == ["recording"] and records[0].metadata == metadata


def test_a_one_finger_recording_goes_on_one_channel(tmp_path: Path) -> None:
    """A trials/simulate recording has no finger suffix: every column on /hand, the unit of
    each from its name."""
    t = np.arange(150) / 100.0
    path = tmp_path / "sweep.csv"
    write_recording(path, {"t": t, "pressure_kpa": 50 * t, "angle_deg": 20 * np.sin(t),
                           "sensor_mv": 1000 + t}, {"finger": "index", "trial": "pressure_sweep"})
    with open(export(path, "mcap", tmp_path / "sweep.mcap"), "rb") as f:
        messages = list(mcap.reader.make_reader(f).iter_messages())
    assert len(messages) == 150 and {c.topic for _, c, _ in messages} == {"/hand"}
    _, channel, first = messages[0]
    assert json.loads(channel.metadata["units"]) == {"t": "s", "pressure_kpa": "kPa", "angle_deg": "deg",
                                                     "sensor_mv": "mV"}
    assert json.loads(messages[-1][2].data)["angle_deg"] == pytest.approx(20 * math.sin(1.49), rel=1e-5)
    assert first.log_time == 0 and messages[-1][2].log_time == 1_490_000_000


def test_export_refuses_in_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "r.csv"
    write_recording(path, {"t": np.arange(3) / 10, "angle_deg": np.zeros(3)})
    out = tmp_path / "r.mat"
    out.write_text("keep")
    assert main(["export", str(path), "--to", "mat"]) == 2
    assert main(["export", str(path), "--to", "mat", "-o", str(path)]) == 2
    assert main(["export", str(tmp_path / "none.csv"), "--to", "parquet"]) == 2
    pairs = tmp_path / "pairs.csv"
    write_recording(pairs, {"sensor_mv": np.arange(3.0), "angle_deg": np.arange(3.0)})
    assert main(["export", str(pairs), "--to", "mcap"]) == 2
    ragged = tmp_path / "ragged.csv"
    ragged.write_text("t,angle_deg\n# finger: index\n0,1\n0.1,2,3\n")
    assert main(["export", str(ragged), "--to", "parquet"]) == 2
    errors = capsys.readouterr().err.strip().splitlines()
    assert len(errors) == 5 and all(e.startswith("hand-service export: error: ") for e in errors)
    assert errors[4].endswith("ragged.csv:4: 3 fields where the header has 2")
    assert "exists already" in errors[0] and "replace the recording" in errors[1]
    assert "no 'numeric 't'" not in errors[3] and "'t' column" in errors[3]
    assert out.read_text() == "keep"
    assert main(["export", str(path), "--to", "mat", "--force"]) == 0 and out.read_bytes()[:6] == b"MATLAB"


def test_a_missing_optional_package_is_one_line(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "r.csv"
    write_recording(path, {"t": np.arange(3) / 10, "angle_deg": np.zeros(3)})
    for module in ("pyarrow", "pyarrow.parquet", "mcap", "mcap.writer"):
        monkeypatch.setitem(sys.modules, module, None)  # import fails: as if not installed
    assert main(["export", str(path), "--to", "parquet"]) == 2
    assert main(["export", str(path), "--to", "mcap"]) == 2
    errors = capsys.readouterr().err.strip().splitlines()
    assert errors == [f"hand-service export: error: this format needs the Python package '{p}': "
                      f"pip install 'hand-service[export]' (or pip install {p})" for p in ("pyarrow", "mcap")]


# the CSV itself: the header first, so numpy's genfromtxt(names=True) and pandas both read it


def test_pandas_and_numpy_read_a_daemon_recording_in_one_line(recording: Path, csv_file) -> None:
    header, cells, _ = csv_file
    assert recording.read_text().split("\n", 1)[0] == ",".join(header)  # the names come first
    table = np.genfromtxt(recording, delimiter=",", names=True, comments="#")
    assert list(table.dtype.names) == header
    for name in header:
        if name != "state" and not name.startswith("mode_"):
            assert_same_column(name, cells[name], table[name])
    frame = pd.read_csv(recording, comment="#")
    assert list(frame.columns) == header
    for name in header:
        assert_same_column(name, cells[name], frame[name].tolist())


def test_pandas_and_numpy_read_a_written_recording(tmp_path: Path) -> None:
    from hand_service.recording import read_recording

    t = np.arange(200) / 100.0
    path = tmp_path / "release.csv"
    write_recording(path, {"t": t, "pressure_kpa": np.zeros(200), "angle_deg": 30 * np.exp(-t)},
                    {"finger": "index", "sample_rate_hz": 100, "trial": "release"})
    table = np.genfromtxt(path, delimiter=",", names=True, comments="#")
    assert table.dtype.names == ("t", "pressure_kpa", "angle_deg") and table.shape == (200,)
    np.testing.assert_allclose(table["angle_deg"], 30 * np.exp(-t), rtol=1e-5)
    assert read_recording(path).metadata == {"finger": "index", "sample_rate_hz": "100", "trial": "release"}
    np.testing.assert_array_equal(pd.read_csv(path, comment="#")["angle_deg"].to_numpy(), table["angle_deg"])


def test_a_recording_with_its_metadata_above_the_header_still_reads(tmp_path: Path) -> None:
    """Files written before the header came first: the same columns and metadata."""
    from hand_service.recording import read_recording

    t = np.arange(200) / 100.0
    new = tmp_path / "new.csv"
    write_recording(new, {"t": t, "pressure_kpa": t, "angle_deg": 2 * t}, {"finger": "index", "seed": 3})
    header, *lines = new.read_text().splitlines()
    old = tmp_path / "old.csv"
    old.write_text("\n".join([*lines[:2], header, *lines[2:]]) + "\n")
    assert old.read_text().startswith("# finger: index\n# seed: 3\nt,pressure_kpa,angle_deg\n")
    a, b = read_recording(new), read_recording(old)
    assert a.metadata == b.metadata == {"finger": "index", "seed": "3"}
    np.testing.assert_array_equal(a.angle_deg, b.angle_deg)
    assert main(["export", str(old), "--to", "mat"]) == 0


# bad input: each refused in one line naming the file, the line and the column, before any
# output is written; what the contract leaves open is said, not guessed silently


@pytest.mark.parametrize(("text", "message"), [
    ("a,b\n1,2\n", "bad.csv:1: no 't' column: export takes a recording with a time column"),
    ("t,angle_deg_index,state\n0,1,RUNNING\n0.01,abc,RUNNING\n",
     "bad.csv:3: column 'angle_deg_index': not a number: 'abc'"),
    ("t,flags_index\n0,0\n0.01,x\n", "bad.csv:3: column 'flags_index': not a number: 'x'"),
    ("t,angle_deg\n0,1\nzero,2\n", "bad.csv:3: column 't': not a number: 'zero'"),
    ("t,angle_deg\n0,1\ninf,2\n", "bad.csv:3: column 't': inf where a finite time is required"),
    ("t,angle_deg\n0,1\n0.02,2\n0.01,3\n",
     "bad.csv:4: column 't': t = 0.01 does not increase (previous 0.02)"),
    ("t,angle_deg\n# finger: index\n", "bad.csv: no rows after the header"),
])
@pytest.mark.parametrize("to", ["mat", "parquet", "mcap"])
def test_a_file_that_is_not_a_recording_is_refused(text: str, message: str, to: str, tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "bad.csv"
    path.write_text(text)
    assert main(["export", str(path), "--to", to]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("hand-service export: error: ") and message in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.csv"]  # nothing written


def test_a_missing_output_folder_is_one_line_before_reading(tmp_path: Path,
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "r.csv"
    write_recording(path, {"t": np.arange(3) / 10, "angle_deg": np.zeros(3)})
    not_a_folder = tmp_path / "file"
    not_a_folder.write_text("")
    for to in ("mat", "parquet", "mcap"):
        assert main(["export", str(path), "--to", to, "-o", str(tmp_path / "none" / f"r.{to}")]) == 2
        assert main(["export", str(path), "--to", to, "-o", str(not_a_folder / f"r.{to}")]) == 2
    errors = capsys.readouterr().err.strip().splitlines()
    assert len(errors) == 6, errors
    for missing, file in zip(errors[::2], errors[1::2], strict=True):
        assert missing.endswith(f"cannot write: the folder {tmp_path / 'none'} does not exist"), missing
        assert file.endswith(f"cannot write: {not_a_folder} is not a folder"), file


def test_a_column_of_text_the_contract_does_not_name_is_kept_and_named(
        tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    """`state`, `mode_<f>`, `finger` are text by definition and go without a word; another
    column with a cell that is not a number is written as text, and the warning names it."""
    path = tmp_path / "notes.csv"
    path.write_text("t,angle_deg,state,note,gain\n0,1,RUNNING,start,1\n0.01,2,HOLD,2,1.5\n")
    with caplog.at_level("WARNING", logger="hand_service.export.table"):
        parquet = export(path, "parquet", tmp_path / "notes.parquet")
    warnings = [r.getMessage() for r in caplog.records]
    assert warnings == [f"{path}: not numbers, written as text: 'note' (line 2: 'start')"]
    table = pq.read_table(parquet)
    assert table.column("note").to_pylist() == ["start", "2"]
    assert table.column("state").to_pylist() == ["RUNNING", "HOLD"]
    assert table.column("gain").to_pylist() == [1.0, 1.5]


def test_a_last_line_cut_short_is_dropped_as_every_reader_does(tmp_path: Path) -> None:
    """A daemon killed mid-write: the cut-off last line is dropped (docs/formats.md §1.1)."""
    path = tmp_path / "killed.csv"
    path.write_text("t,angle_deg,pressure_kpa\n0,1,10\n0.01,2,20\n0.02,3,")  # no newline: cut short
    mat = loadmat(export(path, "mat", tmp_path / "killed.mat"), squeeze_me=True)
    np.testing.assert_array_equal(mat["angle_deg"], [1.0, 2.0])
