"""diagnose takes the model as the paper gives it (A, B, k, N) and a signed command, on a
recording made by an integrator apart from the project's simulator."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from hand_service.cli import main
from hand_service.recording import write_recording
from rtcore import Prbm
from rtcore.config import ConfigError
from rtcore.sim import SimFinger, simulate
from tests.diagnose.linear_truth import LinearFinger, random_steps

RATE_HZ = 100.0


def _recording(tmp_path: Path, low_kpa: float, seed: int) -> tuple[Path, Path]:
    finger = LinearFinger()
    rng = np.random.default_rng(seed)
    n = int(20 * RATE_HZ)
    pressure = random_steps(rng, n, RATE_HZ, low_kpa, 80.0)
    angle = finger.angle_deg(pressure, RATE_HZ) + rng.normal(0.0, 0.3, n)
    path, model = tmp_path / "r.csv", tmp_path / "paper.yaml"
    write_recording(path, {"t": np.arange(n) / RATE_HZ, "pressure_kpa": pressure, "angle_deg": angle})
    model.write_text(finger.model_yaml())
    return path, model


def test_the_papers_minimal_model_is_enough(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path, model = _recording(tmp_path, 0.0, seed=1)
    assert main(["diagnose", str(path), "--model", str(model), "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "verdict: consistent" in out, out


def test_a_signed_command_is_simulated_as_it_is(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A vacuum or bipolar drive goes below 0 kPa: clamped, the model would miss every
    negative step and the exact model would look wrong."""
    path, model = _recording(tmp_path, -60.0, seed=2)
    assert main(["diagnose", str(path), "--model", str(model), "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "verdict: consistent" in out, out
    assert "signed input" in out


def test_a_free_finger_has_no_force_point_and_meets_no_object() -> None:
    prbm = Prbm(inertia_kgm2=1.6e-4, damping_nms_per_rad=0.003, stiffness_nm_per_rad=0.57,
                pressure_gain_nm_per_kpa=0.0119, lever_arm_m=0.0)
    angle, _ = simulate(SimFinger(prbm=prbm), np.full(50, 40.0), RATE_HZ)
    assert np.all(np.isfinite(angle)) and angle[-1] > 10.0
    with pytest.raises(ConfigError):
        simulate(SimFinger(prbm=prbm, contact_angle_deg=30.0, contact_stiffness_n_per_m=2000.0),
                 np.full(50, 40.0), RATE_HZ)


def test_point_samples_of_a_continuous_command_are_taken_as_linear_between_them() -> None:
    """A pressure that changed continuously, sampled at 100 Hz: held between samples it
    lags half a sample, which near resonance is a model error of its own."""
    from scipy import signal

    from hand_service.config.model import FingerModel
    from hand_service.diagnose.model.problem import build_problem

    truth = LinearFinger()
    a, b, k, n = (truth.inertia_kgm2, truth.damping_nms_per_rad, truth.stiffness_nm_per_rad,
                  truth.pressure_gain_nm_per_kpa)
    fine_hz, seconds = 20_000.0, 10.0
    t_fine = np.arange(int(seconds * fine_hz)) / fine_hz

    def command(t: np.ndarray) -> np.ndarray:
        return 40.0 + 25.0 * np.sin(2 * np.pi * 1.3 * t) + 12.0 * np.sin(2 * np.pi * 8.5 * t)

    system = signal.StateSpace([[0.0, 1.0], [-k / a, -b / a]], [[0.0], [n / a]], [[180 / np.pi, 0.0]],
                               [[0.0]])
    x0 = np.linalg.solve([[0.0, 1.0], [-k / a, -b / a]], [0.0, -n / a * command(np.zeros(1))[0]])
    _, angle_fine, _ = signal.lsim(system, command(t_fine), t_fine, X0=x0)
    step = int(fine_hz / RATE_HZ)
    t_s, angle = t_fine[::step], angle_fine[::step]
    model = FingerModel(inertia_kgm2=a, stiffness_nm_per_rad=k, damping_nms_per_rad=b,
                        pressure_gain_nm_per_kpa=n)
    errors = {}
    for hold in ("zoh", "point"):
        problem = build_problem(model, t_s, command(t_s), angle, RATE_HZ, input_hold=hold)
        late = slice(int(2 * RATE_HZ), None)  # past the start's transient
        errors[hold] = float(np.sqrt(np.mean((problem.simulate(problem.base) - angle)[late] ** 2)))
    assert errors["point"] < 0.2 * errors["zoh"], errors


@pytest.mark.thorough
def test_a_clean_recording_with_a_lab_sensors_noise_comes_out_clean(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], seed: int = 3) -> None:
    """Noise correlated over 0.1 s on a drifting offset, with ADC steps, on an exact model:
    nothing is missing. Taken for white noise, the same recording looks structured."""
    from tests.diagnose.linear_truth import lab_sensor_noise, quantise

    finger = LinearFinger()
    rng = np.random.default_rng(seed)
    n = int(20 * RATE_HZ)
    pressure = random_steps(rng, n, RATE_HZ, 0.0, 80.0)
    noise, adc = lab_sensor_noise(rng, n, RATE_HZ)
    angle = quantise(finger.angle_deg(pressure, RATE_HZ) + noise, adc)
    path, model = tmp_path / "r.csv", tmp_path / "paper.yaml"
    write_recording(path, {"t": np.arange(n) / RATE_HZ, "pressure_kpa": pressure, "angle_deg": angle})
    model.write_text(finger.model_yaml())
    verdicts = {}
    for kind in ("ar", "white"):
        assert main(["diagnose", str(path), "--model", str(model), "--noise-model", kind, "--quiet"]) == 0
        verdicts[kind] = capsys.readouterr().out.splitlines()[0]
    assert verdicts["ar"] in ("verdict: consistent", "verdict: parameters_only"), verdicts
    assert verdicts["white"] not in ("verdict: consistent", "verdict: parameters_only"), verdicts


def test_effect_ranges_scale_with_the_finger() -> None:
    """A rig 50 times stiffer (and heavier, more damped, stronger: the same motion) with 50
    times the friction: 0.5 N·m, ten times the library's range for the paper's fingers, is
    found at its size instead of being pinned at that range's edge."""
    from hand_service.config.model import FingerModel
    from hand_service.diagnose.concealed.generator import generate
    from hand_service.diagnose.engine import diagnose

    scale = 50.0
    finger = LinearFinger()
    model = FingerModel(inertia_kgm2=finger.inertia_kgm2 * scale,
                        stiffness_nm_per_rad=finger.stiffness_nm_per_rad * scale,
                        damping_nms_per_rad=finger.damping_nms_per_rad * scale,
                        pressure_gain_nm_per_kpa=finger.pressure_gain_nm_per_kpa * scale)
    c = generate(model, {"coulomb_friction": 0.01 * scale}, "steps", duration_s=20.0, noise_deg=0.3,
                 seed=4, perturbation=0.0, conceal_ratio=None)
    d = diagnose(c.nominal, c.t_s, c.pressure_kpa, c.angle_deg, 100.0)
    assert [e.name for e in d.effects][:1] == ["coulomb_friction"], (d.verdict, d.warnings)
    assert d.effects[0].value == pytest.approx(0.5, rel=0.2)


@pytest.mark.parametrize(("key", "value", "message"), [
    ("stiffness_nm_per_rad", 1e300, "rings at 1.2.e\\+151 Hz"),  # it ran for ever
    ("stiffness_nm_per_rad", 1e9, "times the recording's 100 Hz"),  # so did this one, for minutes
    ("damping_nms_per_rad", 1e300, "reaches inf°"),  # a traceback: non-finite residuals
    ("pressure_gain_nm_per_kpa", 1e300, "reaches .*e\\+30"),  # the same
    ("inertia_kgm2", 1e300, "moves .*° where the recorded one moved"),  # `unexplained`, and no word why
    ("pressure_gain_nm_per_kpa", 1e-300, "moves .*e-29.° where"),  # a traceback: SVD did not converge
])
def test_a_model_in_the_wrong_units_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str], key: str,
                                                value: float, message: str) -> None:
    path, model = _recording(tmp_path, 0.0, seed=3)
    lines = [f"{key}: {value!r}" if line.startswith(f"{key}:") else line
             for line in model.read_text().splitlines()]
    model.write_text("\n".join(lines) + "\n")
    assert main(["diagnose", str(path), "--model", str(model), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "in their units?" in err, err
    assert re.search(message, err), err


def test_a_recording_of_another_finger_is_said_of_the_recording(tmp_path: Path,
                                                                 capsys: pytest.CaptureFixture[str]) -> None:
    """Its `# finger: thumb` line against a model of the index: the message named the model
    file ("this model is for finger 'index', not 'thumb'"); the mismatch is the recording's."""
    path, model = _recording(tmp_path, 0.0, seed=4)
    model.write_text("finger: index\n" + model.read_text())
    text = path.read_text().splitlines()
    path.write_text("\n".join([text[0], "# finger: thumb", *text[1:]]) + "\n")
    assert main(["diagnose", str(path), "--model", str(model), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.endswith(f"{path}: recorded from finger 'thumb', but the model is finger 'index'"), err
