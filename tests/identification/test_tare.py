"""The force estimate's tare: the N that zeroes a free hold's estimate restores the
finger's own N/k, whatever k's error."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from hand_service.cli import main
from hand_service.config.profile import DEFAULT_PROFILE, load_profile
from hand_service.identification.tare import MIN_EFFECTIVE_KPA, apply_tare, tare_from_recording, tare_gain
from hand_service.identification.trials import Trial
from hand_service.recording import read_recording


def _free_hold(k_error: float, n_error: float) -> tuple:
    truth = load_profile(None)
    true = truth.finger("index").model
    angle_rad = math.radians(80.0)
    chamber_kpa = true.stiffness_nm_per_rad * angle_rad / true.pressure_gain_nm_per_kpa  # N p = k θ, free
    mine = true.with_changes(stiffness_nm_per_rad=true.stiffness_nm_per_rad * (1.0 + k_error),
                             pressure_gain_nm_per_kpa=true.pressure_gain_nm_per_kpa * (1.0 + n_error))
    lever_m = mine.prbm("test").lever_arm_m
    torque_nm = mine.pressure_gain_nm_per_kpa * chamber_kpa - mine.stiffness_nm_per_rad * angle_rad
    estimate_n = torque_nm / lever_m
    return truth, true, mine, np.full(50, estimate_n), np.full(50, chamber_kpa)


@pytest.mark.parametrize("k_error, n_error", [(0.05, -0.05), (-0.05, 0.05), (0.05, 0.05), (0.0, 0.0)])
def test_the_tare_restores_the_fingers_ratio(k_error: float, n_error: float) -> None:
    _, true, mine, estimate, chamber = _free_hold(k_error, n_error)
    tare = tare_gain(mine, "index", estimate, chamber)
    ratio = tare.gain_after_nm_per_kpa / mine.stiffness_nm_per_rad
    assert ratio == pytest.approx(true.pressure_gain_nm_per_kpa / true.stiffness_nm_per_rad, rel=1e-9)
    assert tare.gain_change_pct == pytest.approx(100.0 * ((1.0 + k_error) / (1.0 + n_error) - 1.0), rel=1e-6)


def test_the_tare_writes_only_its_fingers_gain() -> None:
    truth, _, mine, estimate, chamber = _free_hold(0.05, -0.05)
    tare = tare_gain(mine, "index", estimate, chamber)
    tared = apply_tare(truth, tare)
    assert tared.finger("index").model.pressure_gain_nm_per_kpa == tare.gain_after_nm_per_kpa
    assert tared.finger("thumb").model == truth.finger("thumb").model


def test_the_tare_refuses_a_hold_it_cannot_read() -> None:
    _, _, mine, estimate, chamber = _free_hold(0.05, -0.05)
    with pytest.raises(ValueError, match="effective pressure"):
        tare_gain(mine, "index", estimate, np.full(50, 0.5 * MIN_EFFECTIVE_KPA))
    with pytest.raises(ValueError, match="one chamber pressure per estimate"):
        tare_gain(mine, "index", estimate, chamber[:-1])
    with pytest.raises(ValueError, match="non-finite"):
        tare_gain(mine, "index", np.full(50, np.nan), chamber)


def _hold_file(tmp_path: Path, measured: bool = True) -> tuple[Path, float]:
    """A free hold of the true index at 80° (N p = k θ) with 0.3° angle and 0.5 kPa noise."""
    true = load_profile(None).finger("index").model
    rng = np.random.default_rng(4)
    samples = 300
    angle_deg = 80.0 + 0.3 * rng.standard_normal(samples)
    chamber_kpa = true.stiffness_nm_per_rad * math.radians(80.0) / true.pressure_gain_nm_per_kpa
    columns = {"t": np.arange(samples) / 100.0, "pressure_kpa": np.full(samples, chamber_kpa),
               "angle_deg": angle_deg}
    if measured:
        columns["pressure_meas_kpa"] = chamber_kpa + 0.5 * rng.standard_normal(samples)
    path = Trial("hold", "index", columns, {"finger": "index"}).write(tmp_path / "hold.csv")
    return path, true.pressure_gain_nm_per_kpa / true.stiffness_nm_per_rad


def test_a_recorded_hold_tares_the_ratio(tmp_path: Path) -> None:
    path, true_ratio = _hold_file(tmp_path)
    _, _, mine, _, _ = _free_hold(0.05, -0.05)
    tare = tare_from_recording(read_recording(path), mine, "index")
    ratio = tare.gain_after_nm_per_kpa / mine.stiffness_nm_per_rad
    assert ratio == pytest.approx(true_ratio, rel=2e-3)  # the noise's share of the mean
    assert tare.gain_change_pct == pytest.approx(100.0 * (1.05 / 0.95 - 1.0), abs=0.3)
    loop = {"hysteresis": {"torque_nm": 0.004, "travel_deg": 0.4}}
    looped = mine.with_changes(effects={**mine.effects, **loop})
    with_loop = tare_from_recording(read_recording(path), looped, "index", with_loop=True)
    assert with_loop.gain_after_nm_per_kpa != pytest.approx(tare.gain_after_nm_per_kpa, rel=1e-6)
    unlooped = tare_from_recording(read_recording(path), looped, "index", with_loop=False)
    assert unlooped.gain_after_nm_per_kpa == pytest.approx(tare.gain_after_nm_per_kpa, rel=1e-12)


def test_calibrate_tare_writes_n_back(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path, true_ratio = _hold_file(tmp_path)
    mine = tmp_path / "mine.yaml"
    mine.write_text(DEFAULT_PROFILE.read_text())
    out = tmp_path / "tare.json"
    assert main(["calibrate", "tare", str(path), "--model", str(mine), "--finger", "index",
                 "--json", str(out), "--update-profile", str(mine)]) == 0
    data = json.loads(out.read_text())
    model = load_profile(mine).finger("index").model
    assert model.pressure_gain_nm_per_kpa == pytest.approx(data["pressure_gain_nm_per_kpa"], rel=1e-6)
    assert model.pressure_gain_nm_per_kpa / model.stiffness_nm_per_rad == pytest.approx(true_ratio, rel=2e-3)
    assert "| N after (N·m/kPa) |" in capsys.readouterr().out
    (tmp_path / "unmeasured").mkdir()
    unmeasured, _ = _hold_file(tmp_path / "unmeasured", measured=False)
    assert main(["calibrate", "tare", str(unmeasured), "--model", str(mine), "--finger", "index"]) == 2
