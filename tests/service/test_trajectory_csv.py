"""Trajectory files: modes from the columns, resampling, and clear errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hand_service.config.profile import load_profile
from hand_service.errors import UserError
from hand_service.service.trajectory import NOT_DRIVEN
from hand_service.service.trajectory_csv import read_trajectory
from rtcore import MODE_FORCE, MODE_POSITION, MODE_VENT

PROFILE = load_profile(None)


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "traj.csv"
    path.write_text(text)
    return path


def test_position_then_force_then_vent(tmp_path: Path) -> None:
    path = write(tmp_path, "# a pinch\nt,angle_ref_deg_index,force_ref_n_index\n"
                           "0,0,\n1,90,\n1.5,,1.0\n2,,1.0\n2.5,,\n3,,\n")
    traj = read_trajectory(path, PROFILE, 100.0)
    i = PROFILE.finger_names.index("index")
    assert traj.n_ticks == 301
    assert traj.angle_deg[50, i] == pytest.approx(45.0)  # linear between rows
    assert traj.velocity_deg_per_s[50, i] == pytest.approx(90.0)
    assert traj.mode[120, i] == MODE_POSITION and traj.angle_deg[120, i] == 90.0  # held to the switch
    assert traj.mode[160, i] == MODE_FORCE and traj.force_n[160, i] == 1.0
    assert traj.mode[260, i] == MODE_VENT
    others = [k for k in range(len(PROFILE.fingers)) if k != i]
    assert np.all(traj.mode[:, others] == NOT_DRIVEN)


SPREADSHEET_IDS = ["excel-de", "sep-line"]


@pytest.mark.parametrize("excel", [b"\xef\xbb\xbft;angle_ref_deg_index;force_ref_n_index\r\n0;0;\r\n1;90;\r\n"
                                   b"1,5;;1,0\r\n2;;1,0\r\n2,5;;\r\n3;;\r\n",
                                   b"sep=;\n# a pinch;;\nt;angle_ref_deg_index;force_ref_n_index\n"
                                   b"0;0;\n1;90;\n1.5;;1.0\n2;;1.0\n2.5;;\n3;;\n"], ids=SPREADSHEET_IDS)
def test_a_spreadsheet_trajectory_reads_as_the_comma_one(tmp_path: Path, excel: bytes) -> None:
    """`;` between fields, decimal commas, a byte-order mark, Excel's `sep=` line."""
    comma = read_trajectory(write(tmp_path, "t,angle_ref_deg_index,force_ref_n_index\n"
                                            "0,0,\n1,90,\n1.5,,1.0\n2,,1.0\n2.5,,\n3,,\n"), PROFILE, 100.0)
    path = tmp_path / "excel.csv"
    path.write_bytes(excel)
    got = read_trajectory(path, PROFILE, 100.0)
    np.testing.assert_array_equal(got.mode, comma.mode)
    np.testing.assert_array_equal(got.angle_deg, comma.angle_deg)
    np.testing.assert_array_equal(got.force_n, comma.force_n)


@pytest.mark.parametrize(("text", "message"), [
    ("t,angle_ref_deg_pinky\n0,0\n1,1\n", "finger 'pinky' is not in the profile"),
    ("t,angle_deg_index\n0,0\n1,1\n", "unknown column"),
    ("time,angle_ref_deg_index\n0,0\n1,1\n", "unknown column"),
    ("t,angle_ref_deg_index\n0,0\n0,1\n", ":3: column 't': t = 0 does not increase"),
    ("t,angle_ref_deg_index\n0,0\n1,abc\n", ":3: column 'angle_ref_deg_index': not a number"),
    ("t,angle_ref_deg_index\n0,0\n1,200\n", "outside the profile's target range [0, 180] deg"),
    ("t,force_ref_n_thumb\n0,0\n1,50\n", "outside the profile's target range [0, 10] N"),
    ("t,force_ref_n_thumb\n0,0\n1,-1\n", "outside the profile's target range [0, 10] N"),
    ("t,angle_ref_deg_index\n0,0\n1e308,1\n", "s at 100 Hz is inf ticks; the limit is 360000"),
    ("t,angle_ref_deg_index,force_ref_n_index\n0,1,1\n1,1,\n", "both an angle and a force"),
    ("t,angle_ref_deg_index\n0,0\n1\n", "1 fields where the header has 2"),
    ("t,angle_ref_deg_index\n0,0\n", "at least two rows"),
    ("t,angle_ref_deg_index\n0,0\n1,nan\n", "finite number"),
])
def test_bad_files_name_the_line_and_column(tmp_path: Path, text: str, message: str) -> None:
    with pytest.raises(UserError, match=message.replace("[", r"\[").replace("]", r"\]")):
        read_trajectory(write(tmp_path, text), PROFILE, 100.0)


@pytest.mark.parametrize(("step_s", "message"), [
    (0.5, r":10: column 't': 4 s at 100 Hz is 401 ticks; the limit is 400 ticks"),
    (1e-6, r":402: more than 400 rows; the limit is 400 rows"),
])
def test_too_long_a_file_stops_at_the_first_row_past_the_limit(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, step_s: float, message: str) -> None:
    """Refused while parsing, at the row past the limit: a bad row after it is never read."""
    from hand_service.service import trajectory_csv
    monkeypatch.setattr(trajectory_csv, "MAX_TICKS", 400)
    monkeypatch.setattr(trajectory_csv, "MAX_ROWS", 400)
    rows = "".join(f"{i * step_s!r},10\n" for i in range(1000))
    path = write(tmp_path, "t,angle_ref_deg_index\n" + rows + "1e9,not a number\n")
    with pytest.raises(UserError, match=message):
        read_trajectory(path, PROFILE, 100.0)
