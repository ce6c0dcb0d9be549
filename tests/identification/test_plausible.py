"""Physical plausibility (docs/formats.md §2.3): a unit slip said in one line, never written."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from hand_service.cli import main
from hand_service.config.model import save_model
from hand_service.config.plausible import (
    DEAD_TIME_DELAY_S,
    DERIVED,
    MODEL_RANGES,
    PROFILE_RANGES,
    VALVE_LAG_TAU_S,
    implausible,
    model_values,
    profile_warnings,
)
from hand_service.config.profile import Profile, load_model
from hand_service.errors import UserError
from hand_service.identification import trials

DOCS = Path(__file__).resolve().parents[2] / "docs" / "formats.md"


def test_the_simulated_hand_is_plausible(profile: Profile) -> None:
    assert profile_warnings(profile) == []


def test_k_in_n_mm_per_rad_is_named(profile: Profile) -> None:
    values = model_values(profile.finger("index").model) | {"stiffness_nm_per_rad": 570.0}
    (line,) = implausible(values)
    assert line.startswith("k = 570 N·m/rad is ") and "N·mm/rad? (570 N·mm/rad = 0.57 N·m/rad)" in line


def test_a_damping_slip_within_bs_range_is_caught_by_the_damping_ratio(profile: Profile) -> None:
    values = model_values(profile.finger("index").model) | {"damping_nms_per_rad": 3.1}
    (line,) = implausible(values)
    assert line.startswith("ζ = ") and "B = 3.1 in N·mm·s/rad?" in line


def test_profile_keys_and_valve_times_name_their_slip(profile: Profile, tmp_path: Path) -> None:
    (line,) = implausible({"pressure_max_kpa": 2.0}, PROFILE_RANGES)
    assert "bar?" in line
    text = (profile.path.read_text().replace("valve_lag: {tau_s: 0.03}", "valve_lag: {tau_s: 30}", 1))
    bad = tmp_path / "ms.yaml"
    bad.write_text(text)
    with pytest.raises(UserError, match=r"tau_s = 30 is out of range .*: ms\? \(30 ms = 0.03 s\)"):
        load_model(bad, "thumb")


def test_every_range_is_in_the_docs() -> None:
    docs = DOCS.read_text()
    ranges = [*MODEL_RANGES.values(), *PROFILE_RANGES.values(), *(d.range for d in DERIVED)]
    for each in ranges:
        assert f"| {each.lower:g}–{each.upper:g} {each.unit}".rstrip() in docs, each.symbol
    for each in (VALVE_LAG_TAU_S, DEAD_TIME_DELAY_S):
        assert f"{each.lower:g}–{each.upper:g} {each.unit}" in docs


@pytest.fixture()
def slipped(profile: Profile, tmp_path: Path) -> Path:
    """The index finger's model with k in N·mm/rad (the issue's 570)."""
    path = tmp_path / "slipped.yaml"
    save_model(profile.finger("index").model.with_changes(stiffness_nm_per_rad=570.0), path)
    return path


def _one_slip_line(err: str) -> str:
    lines = [line for line in err.splitlines() if "N·mm/rad?" in line]
    assert len(lines) == 1, err
    return lines[0]


def test_calibrate_gain_says_the_slip_and_refuses_to_write(profile: Profile, slipped: Path, tmp_path: Path,
                                                          capsys: pytest.CaptureFixture[str]) -> None:
    sweep = trials.pressure_sweep(profile.finger("index"), profile.simulation, seed=4).write(
        tmp_path / "sweep.csv")
    assert main(["calibrate", "gain", str(sweep), "--model", str(slipped)]) == 0
    assert re.search(r"slipped\.yaml: finger index: k = 570 N·m/rad .*N·mm/rad\?",
                     _one_slip_line(capsys.readouterr().err))
    out = tmp_path / "out.yaml"
    assert main(["calibrate", "gain", str(sweep), "--model", str(slipped), "--write-model", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"not writing {out}: k = 570 N·m/rad" in err and not out.exists()


def test_identify_refuses_a_model_whose_mass_is_in_grams(profile: Profile, tmp_path: Path,
                                                         release_files: dict[str, list[Path]],
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    finger = profile.finger("index").model
    grams = tmp_path / "grams.yaml"
    save_model(finger.with_changes(inertia_kgm2=finger.inertia_kgm2 * 1000.0), grams)
    out = tmp_path / "out.yaml"
    files = [str(p) for p in release_files["index"][:2]]
    assert main(["identify", *files, "--model", str(grams), "--write-model", str(out)]) == 2
    err = capsys.readouterr().err
    assert "A = 0.1617 kg·m² is" in err and "g·m²?" in err and not out.exists()


def test_run_says_the_slip_of_its_profile(profile: Profile, tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    text = profile.path.read_text().replace("stiffness_nm_per_rad: 0.570", "stiffness_nm_per_rad: 570", 1)
    mine = tmp_path / "mine.yaml"
    mine.write_text(text)
    main(["run", "--profile", str(mine), "--duration", "0.1", "--no-socket", "--no-realtime",
          "--status", "off"])
    line = _one_slip_line(capsys.readouterr().err)
    assert "mine.yaml: finger index: k = 570 N·m/rad" in line


def test_diagnose_says_the_slip_and_writes_only_a_plausible_refit(
        slipped: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    recording, nominal = tmp_path / "rec.csv", tmp_path / "nominal.yaml"
    assert main(["simulate", "-o", str(recording), "--duration", "10", "--nominal-model", str(nominal)]) == 0
    capsys.readouterr()
    out = tmp_path / "refit.yaml"
    code = main(["diagnose", str(recording), "--model", str(slipped), "--quiet", "--write-model", str(out)])
    err = capsys.readouterr().err
    assert _one_slip_line(err).startswith("warning: ") and "k = 570 N·m/rad" in err
    assert code == 0 if out.exists() else code == 2, err
    if out.exists():  # the refit found k from the data
        assert implausible(model_values(load_model(out))) == []
