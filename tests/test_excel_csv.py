"""A recording saved by a spreadsheet: `;` between fields, decimal commas, a byte-order mark,
Excel's `sep=` line, tabs. Each is read as the project's own CSV is, or refused naming why."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hand_service import cli
from hand_service.errors import UserError
from hand_service.recording import read_recording, write_recording

N_ROWS = 300
RATE_HZ = 100.0


def project_csv(tmp_path: Path) -> Path:
    """A recording as the project writes it: the reference every dialect must read as."""
    t = np.arange(N_ROWS) / RATE_HZ
    path = tmp_path / "reference.csv"
    write_recording(path, {"t": t, "pressure_kpa": 10 * np.sin(t), "angle_deg": 20 * np.sin(t)},
                    {"finger": "index", "sample_rate_hz": RATE_HZ})
    return path


def as_spreadsheet(reference: Path, separator: str, decimal: str, bom: bool = False, sep_line: bool = False,
                   line_end: str = "\n") -> bytes:
    """The reference recording as a spreadsheet saves it: every field separated by
    `separator`, numbers with `decimal` as their mark, `#` lines padded with empty cells."""
    out = []
    lines = reference.read_text().splitlines()
    fields = len(lines[0].split(","))
    if sep_line:
        out.append(f"sep={separator}")
    for line in lines:
        if line.startswith("#"):
            out.append(line + separator * (fields - 1))
            continue
        out.append(separator.join(cell.replace(".", decimal) for cell in line.split(",")))
    text = line_end.join(out) + line_end
    return (b"\xef\xbb\xbf" if bom else b"") + text.encode()


DIALECTS = {
    "excel-de-csv-utf8": dict(separator=";", decimal=",", bom=True, line_end="\r\n"),
    "semicolon-decimal-comma": dict(separator=";", decimal=","),
    "semicolon-decimal-point": dict(separator=";", decimal="."),
    "sep-line": dict(separator=";", decimal=",", sep_line=True, bom=True),
    "tab-decimal-comma": dict(separator="\t", decimal=","),
}


@pytest.mark.parametrize("dialect", DIALECTS, ids=list(DIALECTS))
def test_a_spreadsheet_csv_reads_as_the_projects_own(tmp_path: Path, dialect: str) -> None:
    reference = read_recording(project_csv(tmp_path))
    path = tmp_path / "excel.csv"
    path.write_bytes(as_spreadsheet(project_csv(tmp_path), **DIALECTS[dialect]))
    got = read_recording(path)
    np.testing.assert_array_equal(got.t_s, reference.t_s)
    np.testing.assert_array_equal(got.pressure_kpa, reference.pressure_kpa)
    np.testing.assert_array_equal(got.angle_deg, reference.angle_deg)
    assert got.metadata == reference.metadata  # `# finger: index;;` is finger 'index'


def test_a_spreadsheet_csv_of_several_fingers_finds_the_finger(tmp_path: Path) -> None:
    """The issue's case: `--finger index` on a `;` file answered "no columns for finger 'index'"."""
    t = np.arange(N_ROWS) / RATE_HZ
    path = tmp_path / "hand.csv"
    write_recording(path, {"t": t, "pressure_kpa_index": 3 * t, "angle_deg_index": 2 * t,
                           "pressure_kpa_thumb": t, "angle_deg_thumb": 4 * t})
    excel = tmp_path / "excel.csv"
    excel.write_bytes(as_spreadsheet(path, ";", ",", bom=True))
    np.testing.assert_allclose(read_recording(excel, finger="index").angle_deg, 2 * t, rtol=1e-5)


def test_decimal_commas_between_comma_separated_fields_are_refused_naming_them(tmp_path: Path) -> None:
    path = tmp_path / "excel.csv"
    path.write_bytes(as_spreadsheet(project_csv(tmp_path), ",", ","))
    with pytest.raises(UserError, match=r"excel.csv:\d+: \d+ fields where the header has 3: decimal commas "
                                        r"in a comma-separated file\?") as info:
        read_recording(path)
    assert "\n" not in str(info.value)


def test_the_cli_reads_a_spreadsheet_csv_and_refuses_a_broken_one(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    excel = tmp_path / "excel.csv"
    excel.write_bytes(as_spreadsheet(project_csv(tmp_path), ";", ",", bom=True, line_end="\r\n"))
    assert cli.main(["export", str(excel), "--to", "mat", "-o", str(tmp_path / "excel.mat")]) == 0
    capsys.readouterr()
    broken = tmp_path / "broken.csv"
    broken.write_bytes(as_spreadsheet(project_csv(tmp_path), ",", ","))
    assert cli.main(["export", str(broken), "--to", "mat", "-o", str(tmp_path / "broken.mat")]) == 2
    err = capsys.readouterr().err.strip()
    assert "Traceback" not in err and err.count("\n") == 0, err
    assert "decimal commas in a comma-separated file?" in err
