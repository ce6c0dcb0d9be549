"""The simulated lab trials: what they hold, and that a seed fixes them."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hand_service.cli import main
from hand_service.config.profile import Profile
from hand_service.identification import trials
from hand_service.recording import read_recording


def test_release_holds_then_rings_down(profile: Profile) -> None:
    finger = profile.finger("index")
    trial = trials.release_trial(finger, profile.simulation, offset_deg=30.0, seed=3)
    t, angle = trial.columns["t"], trial.columns["angle_deg"]
    release = float(trial.metadata["release_s"])
    assert 1.0 <= release < 1.01
    hold = angle[t < 1.0]
    assert np.mean(hold) == pytest.approx(30.0, abs=0.1)
    assert np.std(hold) == pytest.approx(profile.simulation["sensor_noise_deg"], rel=0.25)
    assert np.min(angle[(t > release) & (t < release + 0.1)]) < -10.0  # swings through rest
    assert np.abs(angle[t > 4.0]).max() < 1.5  # and rings down
    again = trials.release_trial(finger, profile.simulation, offset_deg=30.0, seed=3)
    np.testing.assert_array_equal(trial.columns["sensor_mv"], again.columns["sensor_mv"])
    other = trials.release_trial(finger, profile.simulation, offset_deg=30.0, seed=4)
    assert not np.array_equal(trial.columns["sensor_mv"], other.columns["sensor_mv"])


def test_sweep_is_slow_and_records_the_chamber(profile: Profile) -> None:
    finger = profile.finger("thumb")
    trial = trials.pressure_sweep(finger, profile.simulation, seed=1)
    p, meas, angle = (trial.columns[k] for k in ("pressure_kpa", "pressure_meas_kpa", "angle_deg"))
    assert p.max() == pytest.approx(finger.pressure_max_kpa)
    assert p[0] == 0.0 and p[-1] == pytest.approx(0.0, abs=1e-9)
    assert np.abs(meas - p).max() < 10.0  # the valve keeps up with a slow sweep
    theta_ss = np.degrees(finger.model.pressure_gain_nm_per_kpa * p / finger.model.stiffness_nm_per_rad)
    assert np.abs(angle - theta_ss).max() < 3.0  # near equilibrium throughout


def test_trials_command_writes_recordings(tmp_path: Path) -> None:
    assert main(["trials", "release", "--count", "2", "--finger", "ring", "--out", str(tmp_path)]) == 0
    assert main(["trials", "valve", "--finger", "ring", "--out", str(tmp_path)]) == 0
    assert main(["trials", "pairs", "--finger", "ring", "--out", str(tmp_path)]) == 0
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == ["ring_pairs_00.csv", "ring_release_00.csv", "ring_release_01.csv", "ring_valve_00.csv"]
    recording = read_recording(tmp_path / "ring_release_01.csv")
    assert recording.metadata["finger"] == "ring" and "simulator_seed" in recording.metadata
    assert main(["trials", "sweep", "--finger", "nope", "--out", str(tmp_path)]) == 2
