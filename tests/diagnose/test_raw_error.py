"""Every model is scored against the raw angle with a constant sensor offset and no drift
(hand_service/diagnose/fitting/raw_error.py), and the plain model's adequacy is judged
before any effect is named: a free offset and drift absorb what a wrong gain does on a slow
command, and an input without authority over the motion must not be explained by a library
effect."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from hand_service.cli import main
from hand_service.recording import write_recording
from rtcore import Prbm
from rtcore.sim import SimFinger, simulate
from tests.diagnose.linear_truth import LinearFinger, random_steps

RATE_HZ = 100.0
DURATION_S = 30.0


def project_finger(finger: LinearFinger) -> SimFinger:
    return SimFinger(prbm=Prbm(inertia_kgm2=finger.inertia_kgm2,
                               damping_nms_per_rad=finger.damping_nms_per_rad,
                               stiffness_nm_per_rad=finger.stiffness_nm_per_rad,
                               pressure_gain_nm_per_kpa=finger.pressure_gain_nm_per_kpa, lever_arm_m=0.0))


def diagnosed(tmp_path: Path, pressure_kpa: np.ndarray, angle_deg: np.ndarray, model: LinearFinger) -> dict:
    recording, model_path, out = tmp_path / "r.csv", tmp_path / "m.yaml", tmp_path / "d.json"
    t = np.arange(pressure_kpa.size) / RATE_HZ
    write_recording(recording, {"t": t, "pressure_kpa": pressure_kpa, "angle_deg": angle_deg})
    model_path.write_text(model.model_yaml())
    assert main(["diagnose", str(recording), "--model", str(model_path), "--json", str(out), "--quiet"]) == 0
    return json.loads(out.read_text())


def test_a_wrong_gain_on_a_slow_ramp_shows_in_the_nominal_error(tmp_path: Path) -> None:
    """A ramp through a model whose pressure gain is 30 % low: the nominal's error is a
    slope, which a free drift term takes whole (the figure read 0.38 deg against an error of
    8.5 deg about its mean). With a constant offset only it stands at its true size."""
    truth = LinearFinger()
    wrong = LinearFinger(pressure_gain_nm_per_kpa=0.7 * truth.pressure_gain_nm_per_kpa)
    n = int(DURATION_S * RATE_HZ)
    pressure = 80.0 * np.arange(n) / n
    clean, _ = simulate(project_finger(truth), pressure, RATE_HZ)
    nominal, _ = simulate(project_finger(wrong), pressure, RATE_HZ)
    angle = clean + np.random.default_rng(3).normal(0.0, 0.1, n)
    result = diagnosed(tmp_path, pressure, angle, wrong)
    gain_error_deg = float(np.std(clean - nominal))  # what no constant offset can take
    assert result["rmse_deg"]["nominal"] > 0.7 * gain_error_deg, result["rmse_deg"]
    assert result["raw_rmse_deg"]["nominal"] > 0.7 * gain_error_deg, result["raw_rmse_deg"]
    assert result["raw_rmse_deg"]["refit"] < 0.05 * gain_error_deg, result["raw_rmse_deg"]


def test_an_input_without_authority_is_said_and_nothing_is_named(tmp_path: Path) -> None:
    """The logged command does not drive the finger: an unlogged one does. No library effect
    may explain that; the answer says the model cannot follow the recording."""
    finger = LinearFinger()
    rng = np.random.default_rng(5)
    n = int(DURATION_S * RATE_HZ)
    logged = random_steps(rng, n, RATE_HZ, 0.0, 80.0)
    hidden = random_steps(rng, n, RATE_HZ, 0.0, 80.0, hold_s=2.3)
    angle, _ = simulate(project_finger(finger), hidden, RATE_HZ)
    result = diagnosed(tmp_path, logged, angle + rng.normal(0.0, 0.1, n), finger)
    assert result["verdict"] == "unexplained", result["verdict"]
    assert result["effects"] == []
    assert any("cannot follow the recording" in w for w in result["warnings"]), result["warnings"]


def test_a_right_model_follows(tmp_path: Path) -> None:
    finger = LinearFinger()
    rng = np.random.default_rng(7)
    n = int(DURATION_S * RATE_HZ)
    pressure = random_steps(rng, n, RATE_HZ, 0.0, 80.0)
    angle, _ = simulate(project_finger(finger), pressure, RATE_HZ)
    result = diagnosed(tmp_path, pressure, angle + rng.normal(0.0, 0.1, n), finger)
    assert result["verdict"] == "consistent", result["warnings"]
    assert not any("cannot follow" in w for w in result["warnings"])
    assert result["raw_rmse_deg"]["refit"] < 0.2


def test_a_raw_refit_follows_only_beyond_the_recordings_fluctuation() -> None:
    """Refitted on the raw angle, the augmented model nests the plain one: a lower raw error
    is no evidence unless the plain model's squared errors are larger beyond fluctuation."""
    from hand_service.diagnose.fitting.raw_difference import LossDifference
    from hand_service.diagnose.fitting.raw_error import RawJudgement

    within = LossDifference(0.00198, 0.006, 18, 164, 2952)  # t = 0.33: a drift taken for creep
    beyond = LossDifference(0.45, 0.02, 40, 70, 2800)  # t = 22: the real EMPS rig's friction
    lower = dict(before_deg=1.121, after_deg=1.120, nominal_held_deg=2.53, after_held_deg=1.24, refitted=True)
    assert not RawJudgement(**lower, difference=within).follows
    assert RawJudgement(**lower, difference=beyond).follows
    assert RawJudgement(**lower).follows  # as fitted on the innovations: no test asked
    said = RawJudgement(**lower, difference=within).sentence(["creep"])
    assert "beyond the recording's fluctuation" in said and "t = 0.33 over 164 stretches" in said
