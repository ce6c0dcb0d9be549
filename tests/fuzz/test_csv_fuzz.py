"""Fuzzed recordings and trajectory files: every bad one is a one-line UserError."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from hand_service.config.profile import load_profile
from hand_service.recording import read_recording
from hand_service.service.trajectory_csv import read_trajectory
from tests.fuzz.conftest import (
    DAEMON_RECORDING_TEXT,
    RECORDING_TEXT,
    TRAJECTORY_TEXT,
    fuzz_tests,
    refused_in_one_line,
)
from tests.fuzz.strategies import encoded, mutated_csv_text, raw_bytes

PROFILE = load_profile(None)

RECORDINGS = st.tuples(
    st.one_of(mutated_csv_text(RECORDING_TEXT).flatmap(encoded),
              mutated_csv_text(RECORDING_TEXT).flatmap(encoded),
              mutated_csv_text(DAEMON_RECORDING_TEXT).flatmap(encoded), raw_bytes()),
    st.sampled_from([None, None, "index", "thumb", "ring", ""]))
TRAJECTORIES = st.tuples(
    st.one_of(mutated_csv_text(TRAJECTORY_TEXT).flatmap(encoded),
              mutated_csv_text(TRAJECTORY_TEXT).flatmap(encoded), raw_bytes()),
    st.sampled_from([None, 100.0, 500.0, 25.0]))


def check_recording(fuzz_dir: Path, case: tuple[bytes, str | None]) -> None:
    data, finger = case
    path = fuzz_dir / "recording.csv"
    path.write_bytes(data)
    refused_in_one_line(lambda: read_recording(path, finger=finger))


def check_trajectory(fuzz_dir: Path, case: tuple[bytes, float | None]) -> None:
    data, rate_hz = case
    path = fuzz_dir / "trajectory.csv"
    path.write_bytes(data)
    refused_in_one_line(lambda: read_trajectory(path, PROFILE, rate_hz))


test_recording_fuzz, test_recording_fuzz_full = fuzz_tests(RECORDINGS, check_recording)
test_trajectory_fuzz, test_trajectory_fuzz_full = fuzz_tests(TRAJECTORIES, check_trajectory)


ENCODINGS = {
    "UTF-8": lambda text: text.encode(),
    "BOM": lambda text: b"\xef\xbb\xbf" + text.encode(),
    "CRLF": lambda text: text.replace("\n", "\r\n").encode(),
    "BOM and CRLF": lambda text: b"\xef\xbb\xbf" + text.replace("\n", "\r\n").encode(),
    "CR": lambda text: text.replace("\n", "\r").encode(),
    "UTF-16": lambda text: text.encode("utf-16"),
}


@settings(max_examples=200, deadline=None, database=None)
@given(encoding=st.sampled_from(sorted(ENCODINGS)),
       angles=st.lists(st.floats(-1e6, 1e6, allow_subnormal=False), min_size=101, max_size=150),
       finger=st.sampled_from(["index", "thumb", "ring"]))
def test_every_form_of_a_valid_recording_reads_the_same(fuzz_dir: Path, encoding: str, angles: list[float],
                                                         finger: str) -> None:
    """docs/formats.md §1.1: a byte-order mark and any line ends are the same file."""
    text = f"# finger: {finger}\nt,pressure_kpa,angle_deg,state\n" + "".join(
        f"{k / 100:.4f},{k},{a!r},RUNNING\n" for k, a in enumerate(angles))
    path = fuzz_dir / "valid.csv"
    path.write_bytes(ENCODINGS[encoding](text))
    rec = read_recording(path)
    np.testing.assert_array_equal(rec.angle_deg, angles)
    assert rec.metadata == {"finger": finger} and rec.text_columns["state"] == ["RUNNING"] * len(angles)


@settings(max_examples=100, deadline=None, database=None)
@given(encoding=st.sampled_from(sorted(ENCODINGS)),
       angles=st.lists(st.floats(0, 180), min_size=2, max_size=20))
def test_every_form_of_a_valid_trajectory_reads_the_same(fuzz_dir: Path, encoding: str,
                                                          angles: list[float]) -> None:
    if encoding == "UTF-16":
        return  # a trajectory is UTF-8 (docs/trajectory.md)
    text = "t,angle_ref_deg_index\n" + "".join(f"{k / 10},{a!r}\n" for k, a in enumerate(angles))
    path = fuzz_dir / "valid_trajectory.csv"
    path.write_bytes(ENCODINGS[encoding](text))
    traj = read_trajectory(path, PROFILE, 100.0)
    np.testing.assert_allclose(traj.angle_deg[::10, PROFILE.finger_names.index("index")], angles)
