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
    # the paired table: per object four pairs and the pool, each placement run under both controllers
    assert len(data["paired"]) == 3 * 5
    for row in data["paired"]:
        placed = sum(row[k] for k in ("both", "force_only", "pressure_only", "neither"))
        assert placed == (8 if row["finger"] == "all" else 2)
    assert "### Paired: both controllers on the same placements" in tables
    assert (tmp_path / "plots" / "pinch_force_slip.png").stat().st_size > 10_000


@pytest.mark.slow
def test_large_run_compares_the_controllers_with_confidence(tmp_path: Path,
                                                             capsys: pytest.CaptureFixture[str]) -> None:
    """200 trials a cell, the setpoints by the margin rule. What the physics gives
    (docs/replicate.md), not an ordering tuned to the paper's: force control better with
    confidence on the chip (constant pressure breaks it on the pairs it was not tuned on)
    and on the coin (the rim's tilt grows with the press); on the screwdriver both hold
    nearly always, constant pressure by a point or two more (the same margin on the pressure
    knob is several times the spare force)."""
    data, tables = run(tmp_path, 200, capsys)
    pooled = data["pooled"]
    for obj in OBJECT_NAMES:
        for c in CONTROLLERS:
            rate = pooled[f"{c}/{obj}"]
            assert rate["trials"] == 800
            assert rate["wilson95"] == pytest.approx(list(wilson_interval(rate["successes"], rate["trials"])))
    for obj in ("chip", "coin"):
        assert pooled[f"force/{obj}"]["wilson95"][0] > pooled[f"pressure/{obj}"]["wilson95"][1], obj
    force, pressure = pooled["force/screwdriver"]["rate"], pooled["pressure/screwdriver"]["rate"]
    assert force > 0.95 and pressure > 0.95 and abs(force - pressure) < 0.03
    paired = {(row["object"], row["finger"]): row for row in data["paired"]}
    for obj in OBJECT_NAMES:
        row = paired[(obj, "all")]
        force = pooled[f"force/{obj}"]["successes"]
        assert row["both"] + row["force_only"] == force
        assert row["difference95"][0] <= row["difference"] <= row["difference95"][1]
    assert paired[("coin", "all")]["paper"]["fisher_exact_p"] < 0.05
    assert data["tuning_rule"] == "lowest holding x 1.5"
    assert "### Force control against constant pressure, all pairs pooled" in tables


@pytest.mark.slow
def test_the_papers_protocol_per_pair_on_a_mismatched_plant(tmp_path: Path,
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    """Tuned per pair by the operator's rule, on a plant that is not the estimator and with
    the lab's calibration run again on it: the force estimate's error within a factor of 2
    of the paper's 0.324 N, and every pair with its own setpoints."""
    out = tmp_path / "pinch.json"
    assert main(["replicate", "--pinch", "--quick", "--pinch-trials", "10", "--pinch-rule", "operator",
                 "--pinch-plant", "mismatched", "--json", str(out)]) == 0
    data, tables = json.loads(out.read_text()), capsys.readouterr().out
    assert 0.324 / 2 < data["estimate_rmse_n"]["force"] < 0.324 * 2
    assert data["plant_mismatch"]["sensor_bow_deg"] > 0.0
    assert {t["finger"] for t in data["tuned"]} == {"index", "middle", "ring", "little"}
    assert "holding in 3 of 3 placed grasps, per finger pair" in data["tuning_rule"]
    # thumb & middle holds chips under constant pressure once the hand opens gradually
    key = ("middle", "chip", "pressure")
    middle = next(t for t in data["tuned"] if (t["finger"], t["obj"], t["controller"]) == key)
    assert middle["lowest_holding_kpa"] == middle["lowest_holding_kpa"]  # a window was found (not NaN)
    cell = next(c for c in data["cells"] if (c["pair"][1], c["object"], c["controller"]) == key)
    assert cell["successes"] > 0
    assert "Force estimate against the plant's true normal force" in tables
