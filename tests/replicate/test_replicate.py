"""replicate: docs/formats.md's JSON from a quick run, the controller's parameters measured
(never the truth's), and the full acceptance (slow)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from hand_service.cli import main
from hand_service.config.profile import DEFAULT_PROFILE
from hand_service.errors import UserError
from hand_service.replicate import run as rep
from hand_service.replicate.tracking import pid_alone

REQUIRED = {
    "ldm": {"stiffness_nm_per_rad", "damping_nms_per_rad", "paper_stiffness_nm_per_rad",
            "paper_damping_nms_per_rad"},
    "position": {"ff_pid_rmse_deg_mean", "ff_pid_max_error_deg_mean", "pid_rmse_deg_mean",
                 "pid_max_error_deg_mean", "fingers"},
    "position.fingers": {"ff_pid_rmse_deg", "ff_pid_max_error_deg", "pid_rmse_deg", "pid_max_error_deg"},
    "force": {"rmse_n", "max_error_n"},
}
FINGERS = ["thumb", "index", "middle", "ring", "little"]


@pytest.fixture(scope="module")
def quick() -> rep.Result:
    return rep.replicate(rep.Options.quick_run())


def check_json(data: dict) -> None:
    assert set(data["ldm"]) == set(FINGERS)
    for finger in FINGERS:
        assert REQUIRED["ldm"] <= set(data["ldm"][finger])
        assert REQUIRED["position.fingers"] <= set(data["position"]["fingers"][finger])
    assert REQUIRED["position"] <= set(data["position"]) and REQUIRED["force"] <= set(data["force"])
    numbers = [v for f in data["ldm"].values() for k, v in f.items() if k in REQUIRED["ldm"]]
    numbers += [data["position"][k] for k in REQUIRED["position"] - {"fingers"}]
    numbers += [data["force"][k] for k in REQUIRED["force"]]
    assert all(isinstance(v, float) and math.isfinite(v) for v in numbers)
    assert data["ldm"]["index"]["paper_stiffness_nm_per_rad"] == 0.570


def test_quick_run_gives_formats_json_and_sane_figures(quick: rep.Result) -> None:
    data = json.loads(json.dumps(quick.to_json()))
    check_json(data)
    position = data["position"]
    assert position["ff_pid_rmse_deg_mean"] < 2.37
    assert position["pid_rmse_deg_mean"] > 2 * position["ff_pid_rmse_deg_mean"]
    assert data["force"]["rmse_n"] < 0.324
    for finger in FINGERS:
        span = data["force"]["fingers"][finger]
        assert span["true_force_min_n"] < 0.1 and span["true_force_max_n"] > 1.9  # the test spans 0-2 N
    assert "| **mean** |" in quick.tables()


def test_the_controller_knows_only_what_was_measured(quick: rep.Result) -> None:
    for measured, truth, controller in zip(quick.measured, quick.truth.fingers, quick.controller.fingers,
                                           strict=True):
        model = controller.model
        assert model.stiffness_nm_per_rad == measured.identified.stiffness_nm_per_rad
        assert model.damping_nms_per_rad == measured.identified.damping_nms_per_rad
        assert model.pressure_gain_nm_per_kpa == measured.gain.pressure_gain_nm_per_kpa
        assert model.effects == measured.valve.effects()
        assert controller.sensor_gain_deg_per_mv == measured.sensor.gain_deg_per_mv
        for name in ("stiffness_nm_per_rad", "damping_nms_per_rad", "pressure_gain_nm_per_kpa"):
            assert getattr(model, name) != getattr(truth.model, name)
            assert getattr(model, name) == pytest.approx(getattr(truth.model, name), rel=0.02)
        assert model.inertia_kgm2 == truth.model.inertia_kgm2  # A is weighed and measured
        lag = model.effects["valve_lag"]["tau_s"]
        assert lag != truth.model.effects["valve_lag"]["tau_s"] and lag == pytest.approx(0.03, rel=0.05)


def test_the_measurements_follow_the_truth(tmp_path: Path) -> None:
    """A hand stiffer than the paper's: the controller's k follows it, not the paper."""
    text = Path(rep.load_profile().path).read_text().replace("stiffness_nm_per_rad: 0.570",
                                                              "stiffness_nm_per_rad: 0.700")
    stiff = tmp_path / "stiff.yaml"
    stiff.write_text(text)
    result = rep.replicate(rep.Options.quick_run(profile=stiff))
    assert result.controller.finger("index").model.stiffness_nm_per_rad == pytest.approx(0.7, rel=0.01)
    assert result.to_json()["ldm"]["index"]["paper_stiffness_nm_per_rad"] == 0.570


def test_pid_alone_has_no_feedforward_and_a_full_integrator(quick: rep.Result) -> None:
    config = pid_alone(quick.controller.hand_config())
    for finger, original in zip(config.fingers, quick.controller.fingers, strict=True):
        assert finger.feedforward == 0 and finger.integrator_limit_kpa == original.pressure_max_kpa
    history = np.array(quick.tuning.history)
    assert np.all(np.diff(history, axis=0) <= 1e-9)  # each stage keeps the best so far
    assert np.all(quick.tuning.rmse_deg < history[0])  # the search improves on the grid


def test_replicate_refuses_a_truth_without_noise_or_valve(tmp_path: Path) -> None:
    text = Path(rep.load_profile().path).read_text()
    quiet = tmp_path / "quiet.yaml"
    quiet.write_text(text.replace("sensor_noise_deg: 0.3", "sensor_noise_deg: 0.1"))
    with pytest.raises(UserError, match=r"sensor noise >= 0\.3 deg"):
        rep.replicate(rep.Options.quick_run(profile=quiet))
    fast = tmp_path / "fast.yaml"
    fast.write_text(text.replace("valve_lag: {tau_s: 0.03}", "valve_lag: {tau_s: 0.01}", 1))
    with pytest.raises(UserError, match="valve lag >= 30 ms"):
        rep.replicate(rep.Options.quick_run(profile=fast))


# the command end to end (its tables, JSON and figures, in its own process):
# tests/commands/test_progress.py's test_replicate_says_its_wall_time, which runs it once for both


@pytest.mark.slow
def test_full_replicate_meets_the_acceptance() -> None:
    result = rep.replicate(rep.Options())
    data = result.to_json()
    check_json(data)
    position = data["position"]
    assert position["ff_pid_rmse_deg_mean"] <= 2.37
    assert position["pid_rmse_deg_mean"] >= 3 * position["ff_pid_rmse_deg_mean"]
    assert data["force"]["rmse_n"] <= 0.324
    for finger in data["ldm"].values():
        assert abs(finger["stiffness_error_pct"]) < 1.0 and abs(finger["damping_error_pct"]) < 5.0



def test_a_profile_finger_in_the_wrong_units_is_one_line(tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    """The thumb's k at 1e300 (ringing at 1.7e151 Hz at a 100 Hz control rate): the simulated
    hand ran for ever; now one line, before anything is simulated."""
    text = DEFAULT_PROFILE.read_text()
    assert text.count("stiffness_nm_per_rad: 0.6541") == 1
    profile = tmp_path / "wrong_units.yaml"
    profile.write_text(text.replace("stiffness_nm_per_rad: 0.6541", "stiffness_nm_per_rad: 1e300"))
    assert main(["replicate", "--quick", "--quiet", "--profile", str(profile)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "thumb: the finger rings at 1.67e+151 Hz" in err, err
