"""calibrate gain, sensor and valve: accuracy on simulated data, the write-back, bad input."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from hand_service.cli import main
from hand_service.config.profile import DEFAULT_PROFILE, Profile, load_model, load_profile
from hand_service.errors import UserError
from hand_service.identification import trials
from hand_service.identification.calibration import (
    fit_pressure_gain,
    fit_sensor_map,
    fit_valve,
    valve_response_kpa,
)
from hand_service.recording import read_recording, write_recording
from tests.identification.conftest import with_effect


@pytest.fixture(scope="module")
def sweep_file(profile: Profile, tmp_path_factory: pytest.TempPathFactory) -> Path:
    directory = tmp_path_factory.mktemp("sweep")
    sweep = trials.pressure_sweep(profile.finger("middle"), profile.simulation, seed=5)
    return sweep.write(directory / "sweep.csv")


@pytest.mark.parametrize("pressure", ["measured", "command"])
def test_gain_from_a_slow_sweep(profile: Profile, sweep_file: Path, pressure: str) -> None:
    model = profile.finger("middle").model
    fit = fit_pressure_gain(read_recording(sweep_file), model, pressure)
    assert fit.pressure_gain_nm_per_kpa == pytest.approx(model.pressure_gain_nm_per_kpa, rel=0.002)
    assert fit.r_squared > 0.9998
    assert fit.rmse_deg < 1.0
    if pressure == "command":  # the angle trails the command by the valve (35 ms) and B/k (2 ms)
        assert 0.03 < fit.lag_s < 0.05
    assert fit.pressure_column == ("pressure_meas_kpa" if pressure == "measured" else "pressure_kpa")


def test_gain_honours_the_models_static_effects(profile: Profile, tmp_path: Path) -> None:
    """A pressure dead zone in the truth: the model that knows it gets N right; the plain
    one does not, and its fit says so."""
    finger = with_effect(profile.finger("index"), "pressure_deadzone", {"threshold_kpa": 20.0})
    path = trials.pressure_sweep(finger, profile.simulation, seed=8).write(tmp_path / "dz.csv")
    knows = fit_pressure_gain(read_recording(path), finger.model)
    plain = fit_pressure_gain(read_recording(path), profile.finger("index").model)
    true_gain = finger.model.pressure_gain_nm_per_kpa
    assert knows.pressure_gain_nm_per_kpa == pytest.approx(true_gain, rel=0.005)
    assert abs(plain.pressure_gain_nm_per_kpa / true_gain - 1) > 0.02
    assert plain.rmse_deg > 3 * knows.rmse_deg


def test_gain_needs_k_and_a_sweep(profile: Profile, sweep_file: Path, tmp_path: Path) -> None:
    model = profile.finger("middle").model
    with pytest.raises(UserError, match="no 'stiffness_nm_per_rad', needed for calibrate gain"):
        fit_pressure_gain(read_recording(sweep_file), model.with_changes(stiffness_nm_per_rad=None))
    flat = tmp_path / "flat.csv"
    t = np.arange(300) / 100.0
    write_recording(flat, {"t": t, "pressure_kpa": np.full(300, 50.0), "angle_deg": np.full(300, 40.0)})
    with pytest.raises(UserError, match="spans only 0 kPa"):
        fit_pressure_gain(read_recording(flat), model)
    with pytest.raises(UserError, match="reported pressure_meas_kpa in 0% of the samples"):
        fit_pressure_gain(read_recording(flat), model, "measured")


def test_sensor_map_per_finger(profile: Profile, tmp_path: Path) -> None:
    columns: dict[str, list] = {"sensor_mv": [], "angle_deg": [], "finger": []}
    for i, name in enumerate(("index", "thumb")):
        pairs = trials.sensor_pairs(profile.finger(name), profile.simulation, seed=i, readings_per_angle=4)
        for key in columns:
            columns[key].extend(pairs.columns[key])
    path = tmp_path / "pairs.csv"
    write_recording(path, {k: np.asarray(v) for k, v in columns.items()})
    fits = {f.finger: f for f in fit_sensor_map(read_recording(path, required=("sensor_mv", "angle_deg"),
                                                               min_duration_s=0.0))}
    assert set(fits) == {"index", "thumb"}
    for name, fit in fits.items():
        truth = profile.finger(name)
        assert fit.gain_deg_per_mv == pytest.approx(truth.sensor_gain_deg_per_mv, rel=0.005)
        assert fit.offset_deg == pytest.approx(truth.sensor_offset_deg, abs=0.5)
        assert fit.r_squared > 0.9999 and fit.pairs == 64


@pytest.mark.parametrize(("body", "message"), [
    ("sensor_mv,angle_deg\n1,2\n2,3\n", "has 2 pair(s)"),
    ("sensor_mv,angle_deg\n5,2\n5,3\n5,4\n", "every sensor_mv is the same"),
    ("sensor_mv,angle\n1,2\n2,3\n3,4\n", "missing required column 'angle_deg'"),
])
def test_sensor_bad_input(tmp_path: Path, body: str, message: str) -> None:
    path = tmp_path / "pairs.csv"
    path.write_text(body)
    with pytest.raises(UserError, match=message.replace("(", r"\(").replace(")", r"\)")):
        fit_sensor_map(read_recording(path, required=("sensor_mv", "angle_deg"), min_duration_s=0.0))


def test_valve_lag_and_dead_time_from_steps(profile: Profile, tmp_path: Path) -> None:
    finger = with_effect(with_effect(profile.finger("thumb"), "valve_lag", {"tau_s": 0.045}),
                         "dead_time", {"delay_s": 0.012})
    path = trials.valve_steps(finger, profile.simulation, seed=2).write(tmp_path / "valve.csv")
    fit = fit_valve(read_recording(path))
    assert fit.tau_s == pytest.approx(0.045, rel=0.05)
    assert fit.delay_s == pytest.approx(0.012, abs=0.001)
    assert fit.rmse_kpa < 0.6  # the pressure sensor's noise is 0.5 kPa


def test_a_valve_that_vents_slower_than_it_fills(profile: Profile, tmp_path: Path) -> None:
    """The one-lag fit lands between the fill's and the vent's lags; with vent=True both are
    recovered and written into the effects block (valve_vent_lag)."""
    finger = with_effect(with_effect(with_effect(profile.finger("thumb"), "valve_lag", {"tau_s": 0.03}),
                                     "valve_vent_lag", {"tau_s": 0.12}), "dead_time", {"delay_s": 0.012})
    path = trials.valve_steps(finger, profile.simulation, seed=2).write(tmp_path / "valve.csv")
    one = fit_valve(read_recording(path))
    assert 0.035 < one.tau_s < 0.11 and "valve_vent_lag" not in one.effects()
    fit = fit_valve(read_recording(path), vent=True)
    assert fit.tau_s == pytest.approx(0.03, rel=0.05)
    assert fit.vent_tau_s == pytest.approx(0.12, rel=0.05)
    assert fit.delay_s == pytest.approx(0.012, abs=0.001)
    assert fit.rmse_kpa < 0.6 < one.rmse_kpa
    assert fit.effects()["valve_vent_lag"] == {"tau_s": fit.vent_tau_s}
    mine = tmp_path / "mine.yaml"
    mine.write_text(DEFAULT_PROFILE.read_text())
    assert main(["calibrate", "valve", str(path), "--model", str(mine), "--finger", "thumb", "--vent",
                 "--json", str(tmp_path / "v.json"), "--update-profile", str(mine)]) == 0
    assert json.loads((tmp_path / "v.json").read_text())["valve_vent_tau_s"] == pytest.approx(fit.vent_tau_s)
    written = load_profile(mine).finger("thumb").model.effects
    assert written["valve_vent_lag"]["tau_s"] == pytest.approx(fit.vent_tau_s)
    assert written["valve_lag"]["tau_s"] == pytest.approx(fit.tau_s)


def test_valve_response_vents_with_its_own_lag() -> None:
    command = np.r_[np.full(30, 100.0), np.zeros(40)]
    response = valve_response_kpa(command, 0.01, 0.03, 0.0, 0.12)
    top = response[30]
    np.testing.assert_allclose(response[30:], top * np.exp(-np.arange(40) * 0.01 / 0.12), atol=1e-9)


def test_valve_response_is_the_exact_first_order_lag() -> None:
    command = np.r_[np.zeros(5), np.full(40, 100.0)]
    response = valve_response_kpa(command, 0.01, 0.03, 0.005)
    t_after = np.arange(40) * 0.01 - 0.005  # the step reaches the chamber 5 ms after sample 5
    expected = np.where(t_after > 0, 100.0 * (1 - np.exp(-np.clip(t_after, 0, None) / 0.03)), 0.0)
    np.testing.assert_allclose(response[5:], expected, atol=1e-9)


def test_calibrate_cli_updates_a_profile_in_place(profile: Profile, sweep_file: Path, tmp_path: Path,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    mine = tmp_path / "mine.yaml"
    mine.write_text(DEFAULT_PROFILE.read_text())
    out = tmp_path / "gain.json"
    assert main(["calibrate", "gain", str(sweep_file), "--model", str(mine), "--finger", "middle", "--json",
                 str(out), "--update-profile", str(mine),
                 "--write-model", str(tmp_path / "middle.yaml")]) == 0
    data = json.loads(out.read_text())
    assert {"pressure_gain_nm_per_kpa", "r_squared", "rmse_deg"} <= set(data)
    updated = load_profile(mine).finger("middle").model.pressure_gain_nm_per_kpa
    assert updated == pytest.approx(data["pressure_gain_nm_per_kpa"], rel=1e-6)
    assert load_model(tmp_path / "middle.yaml").pressure_gain_nm_per_kpa == data["pressure_gain_nm_per_kpa"]
    assert "# Every finger's valve" in mine.read_text()  # comments survive
    assert "| N (N·m/kPa) |" in capsys.readouterr().out

    pairs = trials.sensor_pairs(profile.finger("little"), profile.simulation, seed=3)
    pairs = pairs.write(tmp_path / "p.csv")
    assert main(["calibrate", "sensor", str(pairs), "--update-profile", str(mine), "--json", str(out)]) == 0
    fit = json.loads(out.read_text())["fingers"]["little"]
    assert {"sensor_gain_deg_per_mv", "sensor_offset_deg", "r_squared"} <= set(fit)
    assert load_profile(mine).finger("little").sensor_offset_deg == pytest.approx(fit["sensor_offset_deg"],
                                                                                  abs=1e-4)

    valve = trials.valve_steps(profile.finger("ring"), profile.simulation, seed=4).write(tmp_path / "v.csv")
    assert main(["calibrate", "valve", str(valve), "--model", str(mine), "--finger", "ring",
                 "--update-profile", str(mine)]) == 0
    lag = load_profile(mine).finger("ring").model.effects["valve_lag"]["tau_s"]
    assert lag == pytest.approx(0.03, rel=0.05) and lag != 0.03


def test_calibrate_bad_input_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pairs = tmp_path / "pairs.csv"
    pairs.write_text("sensor_mv,angle_deg\n1,2\n2,3\n3,5\n")
    for args, message in ((["sensor", str(pairs), "--write-model", str(tmp_path / "x.yaml")],
                           "not part of a model file"),
                          (["sensor", str(pairs), "--update-profile", str(DEFAULT_PROFILE)],
                           "no finger finger"),
                          (["gain", str(pairs), "--model", str(DEFAULT_PROFILE), "--finger", "index"],
                           "missing required column 't'")):
        assert main(["calibrate", *args]) == 2
        err = capsys.readouterr().err
        assert message in err and err.strip().count("\n") == 0, err


def _unreported(path: Path, out: Path, share: float) -> Path:
    """`path` with pressure_meas_kpa NaN in `share` of its rows, spread over the recording
    (the format's 'NaN where the board does not report it')."""
    recording = read_recording(path)
    rows = np.random.default_rng(3).random(len(recording)) < share
    columns = {"t": recording.t_s, "pressure_kpa": recording.pressure_kpa, "angle_deg": recording.angle_deg,
               **recording.columns}
    columns["pressure_meas_kpa"] = np.where(rows, np.nan, columns["pressure_meas_kpa"])
    write_recording(out, columns, recording.metadata)
    return out


def test_a_board_that_leaves_the_measured_pressure_out_now_and_then_is_calibrated_as_one_that_does_not(
        profile: Profile, sweep_file: Path, tmp_path: Path) -> None:
    """A few NaN readings of pressure_meas_kpa (documented) were refused by the valve fit and
    made the gain fit fall back silently to the command: both now fit on what was reported."""
    model = profile.finger("middle").model
    gapped = _unreported(sweep_file, tmp_path / "sweep_gaps.csv", 0.05)
    fit = fit_pressure_gain(read_recording(gapped), model, "auto")
    assert fit.pressure_column == "pressure_meas_kpa"
    assert fit.pressure_gain_nm_per_kpa == pytest.approx(model.pressure_gain_nm_per_kpa, rel=0.002)
    finger = with_effect(profile.finger("thumb"), "valve_lag", {"tau_s": 0.045})
    steps = trials.valve_steps(finger, profile.simulation, seed=2).write(tmp_path / "valve.csv")
    valve = fit_valve(read_recording(_unreported(steps, tmp_path / "valve_gaps.csv", 0.05)))
    assert valve.tau_s == pytest.approx(0.045, rel=0.05)
    with pytest.raises(UserError, match="reported pressure_meas_kpa in 19% of"):  # mostly missing: said so
        fit_valve(read_recording(_unreported(steps, tmp_path / "valve_sparse.csv", 0.8)))
