"""Shared simulated lab data for the identify, calibrate and replicate tests."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from hand_service.config.profile import FingerProfile, Profile, load_profile
from hand_service.identification import trials

RELEASES_PER_FINGER = 10


@pytest.fixture(scope="session")
def profile() -> Profile:
    return load_profile()


@pytest.fixture(scope="session")
def release_files(profile: Profile, tmp_path_factory: pytest.TempPathFactory) -> dict[str, list[Path]]:
    """Table 1's trials: 10 push-and-release recordings per finger, 0.3 deg noise, 100 Hz."""
    directory = tmp_path_factory.mktemp("releases")
    files = {}
    for i, finger in enumerate(profile.fingers):
        made = trials.release_trials(finger, profile.simulation, RELEASES_PER_FINGER, seed=100 + i)
        files[finger.name] = [t.write(directory / f"{finger.name}_{k:02d}.csv") for k, t in enumerate(made)]
    return files


def with_effect(finger: FingerProfile, name: str, params: dict[str, float]) -> FingerProfile:
    """The finger with one more effect in its truth."""
    return dataclasses.replace(finger, model=finger.model.with_changes(effects={**finger.model.effects,
                                                                                 name: params}))
