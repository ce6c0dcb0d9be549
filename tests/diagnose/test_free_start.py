"""A start not known to be at rest counts, its motion a nuisance (problem.build_problem's
`free_start`, noise.start_motion): the first decay times carry what a dead zone does while
the command first crosses it, and a recording cut mid-swing is still clean, its noise
still the sensor's."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import hand_service.diagnose.residual.noise as noise
from tests.diagnose.truth import cases as cs
from tests.diagnose.truth.battery import diagnose_in_process

# a stiff finger under a chirp whose command stays above a 2.4 kPa dead zone after its
# first 20 ms: past the start, the dead zone is an offset the sensor's own absorbs
DEAD_ZONE = cs.CaseSpec("pressure_deadzone", "chirp", 2, "evident", "stiff", 200.0)
CLEAN = cs.CaseSpec("clean", "steps", 0, "none", "ringing", 200.0)
QUIET = ("consistent", "parameters_only", "insufficient_excitation")


def test_a_dead_zone_crossed_only_at_the_start_is_named(tmp_path: Path) -> None:
    case = cs.build(DEAD_ZONE)
    assert case.observable
    command = case.trajectory.command_kpa
    assert np.mean(command[int(0.1 * case.rate_hz):] < case.truth.deadzone_kpa) < 0.02
    result = diagnose_in_process(*cs.write(case, tmp_path), tmp_path)
    assert [e["name"] for e in result["effects"]][:1] == ["pressure_deadzone"], result["verdict"]
    found = result["effects"][0]["params"]["threshold_kpa"]
    assert abs(found / case.truth.deadzone_kpa - 1.0) < 0.3


def _cut_mid_swing(tmp_path: Path) -> tuple[Path, Path, float]:
    """The clean ringing recording from where its finger first swings through the rest of
    its first step, at full speed: a start that is not at rest, and not a release; the
    paths of the recording and the model, and the sensor noise's RMS (deg)."""
    case = cs.build(CLEAN)
    rec_path, model_path = cs.write(case, tmp_path)
    rate = case.rate_hz
    command, theta = case.trajectory.command_kpa, case.trajectory.theta_deg
    step = int(np.argmax(np.abs(np.diff(command)) > 1.0)) + 1
    rest = float(np.median(theta[step + int(0.6 * rate): step + int(0.9 * rate)]))
    cut = step + int(np.argmax((theta[step:] - theta[step - 1]) / (rest - theta[step - 1]) >= 1.0))
    speed = np.abs(np.diff(theta[cut - 1: cut + 1]))[0] * rate
    assert speed > 50.0  # deg/s: far from still
    header = [line for line in rec_path.read_text().splitlines() if line.startswith(("#", "t,"))]
    body = [f"{i / rate:.6f},{command[k]:.5f},{case.measured_deg[k]:.5f}"
            for i, k in enumerate(range(cut, len(command)))]
    cut_path = tmp_path / "cut.csv"
    cut_path.write_text("\n".join(header + body) + "\n")
    return cut_path, model_path, case.sensor.noise_rms_deg


def test_a_clean_recording_that_starts_mid_swing_names_nothing(tmp_path: Path) -> None:
    recording, model, noise_rms_deg = _cut_mid_swing(tmp_path)
    result = diagnose_in_process(recording, model, tmp_path)
    assert result["verdict"] in QUIET, (result["verdict"], result["effects"])
    assert result["noise_deg"] < 1.2 * noise_rms_deg  # the swing is not taken for noise either


def test_without_the_start_nuisance_the_swing_is_taken_for_noise(tmp_path: Path,
                                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    """The control: the first decay times counted with the start trusted at rest. The swing
    the model cannot follow is taken for noise, over four times the sensor's, which would
    hide any effect."""
    monkeypatch.setattr(noise, "start_motion", lambda *args: None)
    recording, model, noise_rms_deg = _cut_mid_swing(tmp_path)
    result = diagnose_in_process(recording, model, tmp_path)
    assert result["noise_deg"] > 3.0 * noise_rms_deg
