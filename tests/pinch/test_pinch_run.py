"""`replicate --pinch` end to end: its errors (quick), a small run with JSON and the
figure, and the large run with its Wilson intervals (slow, in make bench)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from hand_service.cli import main
from hand_service.pinch.objects import OBJECT_NAMES
from hand_service.pinch.stats import wilson_interval
from hand_service.pinch.trials import CONTROLLERS


@pytest.mark.parametrize(("argv", "message"), [
    (["--pinch-trials", "3"], "--pinch-trials needs --pinch"),
    (["--pinch", "--pinch-trials", "0"], "--pinch-trials must be a whole number from 1 to 5000, not 0"),
    (["--pinch", "--trials", "x"], "--trials DIR keeps the recordings of Tables 1 and 2"),
])
def test_bad_pinch_options_give_one_line(argv: list[str], message: str,
                                          capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    argv = [a if a != "x" else str(tmp_path / "rec") for a in argv]
    assert main(["replicate", *argv]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err and len(err.strip().splitlines()) == 1


def run(tmp_path: Path, trials: int, capsys: pytest.CaptureFixture[str]) -> tuple[dict, str]:
    out = tmp_path / "pinch.json"
    assert main(["replicate", "--pinch", "--quick", "--pinch-trials", str(trials), "--json", str(out),
                 "--plots", str(tmp_path / "plots")]) == 0
    return json.loads(out.read_text()), capsys.readouterr().out


@pytest.mark.slow
def test_small_run_prints_tables_3_and_4_beside_the_papers(tmp_path: Path,
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    data, tables = run(tmp_path, 2, capsys)
    assert "### Table 3: PRBM+LDM force control (2 trials a cell)" in tables
    assert "/ 62 % (8/13)" in tables and "/ 40 % (4/10)" in tables  # the paper's thumb & index cells
    assert len(data["cells"]) == 4 * 3 * 2 and all(c["trials"] == 2 for c in data["cells"])
    assert (tmp_path / "plots" / "pinch_force_slip.png").stat().st_size > 10_000


@pytest.mark.slow
def test_large_run_compares_the_controllers_with_confidence(tmp_path: Path,
                                                             capsys: pytest.CaptureFixture[str]) -> None:
    """200 trials a cell. What the simulation found (docs/replicate.md): force control never
    worse than constant pressure beyond the intervals (they overlap or force control's lies
    above), better with confidence on the chip and the coin, by most on the coin."""
    data, tables = run(tmp_path, 200, capsys)
    pooled = data["pooled"]
    margins = {}
    for obj in OBJECT_NAMES:
        rates = {c: pooled[f"{c}/{obj}"] for c in CONTROLLERS}
        assert rates["force"]["trials"] == rates["pressure"]["trials"] == 800
        for c in CONTROLLERS:
            assert rates[c]["wilson95"] == pytest.approx(
                list(wilson_interval(rates[c]["successes"], rates[c]["trials"])))
        assert rates["force"]["wilson95"][1] >= rates["pressure"]["wilson95"][0], obj
        margins[obj] = rates["force"]["rate"] - rates["pressure"]["rate"]
    for obj in ("chip", "coin"):
        assert pooled[f"force/{obj}"]["wilson95"][0] > pooled[f"pressure/{obj}"]["wilson95"][1], obj
    assert max(margins, key=margins.get) == "coin"  # type: ignore[arg-type]
    assert "### Force control against constant pressure, all pairs pooled" in tables
