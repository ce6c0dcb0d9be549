"""pytest-benchmark cases for the model tools (run for real by `make bench`; in `make test`
--benchmark-disable runs each once, as a smoke test)."""

from __future__ import annotations

from pathlib import Path

import pytest

from hand_service.config.profile import Profile, load_profile
from hand_service.identification import trials
from hand_service.identification.identify import identify_trial
from hand_service.recording import read_recording
from hand_service.replicate.tracking import track
from hand_service.simulator import hand_simulator


@pytest.fixture(scope="module")
def profile() -> Profile:
    return load_profile()


def test_identify_one_release(benchmark, profile: Profile, tmp_path: Path) -> None:
    finger = profile.finger("index")
    path = trials.release_trial(finger, profile.simulation, 30.0, seed=1).write(tmp_path / "r.csv")
    recording = read_recording(path)
    result = benchmark(identify_trial, recording, finger.model.inertia_kgm2)
    assert result.stiffness_nm_per_rad == pytest.approx(finger.model.stiffness_nm_per_rad, rel=0.02)


def test_closed_loop_sweep_ten_periods_five_fingers(benchmark, profile: Profile) -> None:
    config = profile.hand_config()
    run = benchmark(track, config, lambda seed: hand_simulator(profile, seed=seed), 1, 10)
    assert run.rmse_deg.max() < 3.0
