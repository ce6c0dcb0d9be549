"""The docs stay reference: diagnose's page short, README rows readable, dates in results only."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
MAX_DIAGNOSE_LINES = 300
MAX_README_LINE = 200
DATE = re.compile(r"\b(?:19|20)\d\d-(?:0[1-9]|1[0-2])-(?:0[1-9]|[12]\d|3[01])\b")
DATED_PAGE = "results.md"  # the one page of dated results


def reference_pages() -> list[Path]:
    return [ROOT / "README.md", *sorted(p for p in DOCS.glob("*.md") if p.name != DATED_PAGE)]


def test_the_diagnose_page_is_a_short_reference() -> None:
    lines = (DOCS / "diagnose.md").read_text().splitlines()
    assert len(lines) <= MAX_DIAGNOSE_LINES, f"docs/diagnose.md has {len(lines)} lines"
    assert (DOCS / "diagnose-design.md").is_file()


def test_every_readme_line_and_table_row_is_readable() -> None:
    long = {number: len(line) for number, line in enumerate((ROOT / "README.md").read_text().splitlines(), 1)
            if len(line) > MAX_README_LINE}
    assert long == {}, f"README.md lines over {MAX_README_LINE} characters (line: length)"


@pytest.mark.parametrize("page", reference_pages(), ids=lambda p: p.name)
def test_dated_results_live_in_results_md_only(page: Path) -> None:
    dated = [f"{number}: {line.strip()[:80]}" for number, line in enumerate(page.read_text().splitlines(), 1)
             if DATE.search(line)]
    assert dated == [], f"{page.name} holds dated lines; move them to docs/{DATED_PAGE}"


def test_the_readmes_numpy_line_keeps_the_text_columns(tmp_path: Path,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    """README's "Reading a recording" numpy line, run as written on a recording with the
    daemon's text columns: `state` and `mode_<f>` come back as text, not NaN."""
    import numpy as np

    from hand_service.recording import write_recording

    line = next(x.strip() for x in (ROOT / "README.md").read_text().splitlines() if "np.genfromtxt(" in x)
    statement = line[: line.rindex(")") + 1]  # `a = np.genfromtxt("run.csv", ...)`, no comment
    write_recording(tmp_path / "run.csv", {"t": np.arange(3) / 100, "state": ["ARMED", "RUNNING", "RUNNING"],
                                           "angle_deg_index": [0.5, 1.0, 1.5],
                                           "mode_index": ["vent", "position", "position"]})
    monkeypatch.chdir(tmp_path)
    scope: dict[str, object] = {"np": np}
    exec(statement, scope)
    table = scope["a"]
    assert [str(s) for s in table["state"]] == ["ARMED", "RUNNING", "RUNNING"]  # type: ignore[index]
    assert [str(s) for s in table["mode_index"]] == ["vent", "position", "position"]  # type: ignore[index]
    np.testing.assert_allclose(table["angle_deg_index"], [0.5, 1.0, 1.5])  # type: ignore[index]


def test_the_first_hour_records_every_trial_kind_with_its_flags() -> None:
    """Step 2 of the README gives each kind `calibrate` needs as a whole command."""
    readme = (ROOT / "README.md").read_text()
    for kind in ("release", "sweep", "valve", "pairs"):
        command = rf"hand-service trials {kind} (--count \d+ )?--finger index --out trials/"
        assert re.search(command, readme), kind
    assert ".venv/bin" in readme and "activate" in readme  # the commands' folder on PATH
