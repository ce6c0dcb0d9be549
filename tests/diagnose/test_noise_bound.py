"""The correlated-noise model may not take the physics (residual/noise_bound.py): a
recording with an end stop the library does not have, whose misfit stands over three times
the sensor's noise, is never called consistent or parameters_only; its clean twin is."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from hand_service.cli import main
from hand_service.recording import write_recording
from tests.diagnose.linear_truth import LinearFinger, lab_sensor_noise, quantise, random_steps

RATE_HZ = 100.0
DURATION_S = 30.0
SUBSTEPS = 20
NOISE_RMS_DEG = float(np.hypot(0.1, 0.3))  # lab_sensor_noise's white and correlated parts


def with_end_stop(finger: LinearFinger, pressure_kpa: np.ndarray, stop_deg: float) -> np.ndarray:
    """The linear finger against a stiff end stop at `stop_deg` (a spring 30 times k with
    damping of its own, pushing back only while pressed), integrated here, apart from the
    project's simulator (semi-implicit Euler, SUBSTEPS per sample, the command held)."""
    a, b, k, n = (finger.inertia_kgm2, finger.damping_nms_per_rad, finger.stiffness_nm_per_rad,
                  finger.pressure_gain_nm_per_kpa)
    stop_rad, contact_k, contact_b = np.radians(stop_deg), 30.0 * k, 10.0 * b
    dt = 1.0 / (RATE_HZ * SUBSTEPS)
    theta = omega = 0.0
    out = np.empty(pressure_kpa.size)
    for i, p in enumerate(pressure_kpa):
        out[i] = np.degrees(theta)
        for _ in range(SUBSTEPS):
            pressed = theta - stop_rad
            contact = contact_k * pressed + contact_b * omega if pressed > 0.0 else 0.0
            omega += dt * (n * p - b * omega - k * theta - max(contact, 0.0)) / a
            theta += dt * omega
    return out


def recording(tmp_path: Path, stop_deg: float | None, seed: int) -> tuple[dict, float]:
    """diagnose's JSON on random steps through a lab's sensor; the RMS of what the end stop
    changes in the angle."""
    finger = LinearFinger()
    rng = np.random.default_rng(seed)
    n = int(DURATION_S * RATE_HZ)
    pressure = random_steps(rng, n, RATE_HZ, 0.0, 80.0, hold_s=2.0)
    free = finger.angle_deg(pressure, RATE_HZ)
    angle = free if stop_deg is None else with_end_stop(finger, pressure, stop_deg)
    noise, step = lab_sensor_noise(rng, n, RATE_HZ, drift_deg=0.2)
    measured = quantise(angle + noise, step)
    path, model, out = tmp_path / "r.csv", tmp_path / "m.yaml", tmp_path / "d.json"
    write_recording(path, {"t": np.arange(n) / RATE_HZ, "pressure_kpa": pressure, "angle_deg": measured})
    model.write_text(finger.model_yaml())
    assert main(["diagnose", str(path), "--model", str(model), "--json", str(out), "--quiet"]) == 0
    return json.loads(out.read_text()), float(np.std(angle - free))


@pytest.mark.thorough
@pytest.mark.parametrize("seed", [1])
def test_an_end_stop_is_not_taken_for_correlated_noise(tmp_path: Path, seed: int) -> None:
    result, stop_rms = recording(tmp_path, 40.0, seed)
    assert result["raw_rmse_deg"]["refit"] > 3.0 * NOISE_RMS_DEG, result["raw_rmse_deg"]
    assert result["verdict"] not in ("consistent", "parameters_only"), result["warnings"]
    assert stop_rms > 1.0


@pytest.mark.parametrize("seed", [1])
def test_its_clean_twin_stays_clean(tmp_path: Path, seed: int) -> None:
    result, _ = recording(tmp_path, None, seed)
    assert result["verdict"] in ("consistent", "parameters_only"), result["warnings"]


@pytest.mark.thorough
def test_a_hysteresis_loop_under_a_pi_loop_is_not_parameters_only(tmp_path: Path) -> None:
    """A case of the independent truth (tests/diagnose/truth/): a rate-independent hysteresis
    loop, outside the library, under a PI loop at 500 Hz, at the strength its calibration
    found for 4 times the sensor's noise. Its residual is smooth enough for the AR filter to
    predict: the innovations came out white, and the answer was `parameters_only`."""
    from tests.diagnose.truth import cases as cs
    from tests.diagnose.truth.battery import diagnose_in_process

    spec = cs.CaseSpec("hysteresis", "pi_steps", 0, "evident", family="stiff", rate_hz=500.0, strength=0.9478)
    case = cs.build(spec)
    assert case.visibility > 3.0, case.visibility  # structure over three times the noise
    cs.write(case, tmp_path)
    result = diagnose_in_process(tmp_path / f"{spec.id}.csv", tmp_path / f"{spec.id}.yaml", tmp_path)
    assert result["verdict"] not in ("consistent", "parameters_only"), result["warnings"]


def _steps_with_structure(structure_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """A command of steps held 3 s at 100 Hz, and a residual of AR(1) sensor noise (0.1 deg)
    plus a smooth transient of `structure_deg` after each step, dying out within 0.4 s: input-
    driven structure that is zero where the finger is at rest."""
    rng = np.random.default_rng(3)
    n = int(DURATION_S * RATE_HZ)
    pressure = np.repeat(rng.uniform(0.0, 80.0, n // 300 + 1), 300)[:n]
    noise = np.zeros(n)
    shocks = rng.normal(0.0, 0.1 * np.sqrt(1.0 - 0.5**2), n)
    for i in range(1, n):
        noise[i] = 0.5 * noise[i - 1] + shocks[i]
    t_in_hold = (np.arange(n) % 300) / RATE_HZ
    transient = structure_deg * (t_in_hold / 0.05) * np.exp(1.0 - t_in_hold / 0.05)
    transient[:300] = 0.0  # the recording starts at rest
    return pressure, noise + transient


def test_the_noise_filter_takes_its_order_from_the_finger_at_rest_where_structure_stands_clear() -> None:
    """The AR order chosen on a residual that is mostly structure is high (it predicts the
    transients from their own past); bounded_order chooses it where the finger is at rest
    instead (AR(1) noise: order 1 or 2), and leaves a residual of noise alone as it was."""
    from types import SimpleNamespace

    from hand_service.diagnose.residual import noise, noise_bound

    finger = SimpleNamespace(prbm=SimpleNamespace(inertia_kgm2=1e-5, damping_nms_per_rad=0.05,
                                                  stiffness_nm_per_rad=0.5))  # decays in 0.1 s
    scored = np.ones(int(DURATION_S * RATE_HZ), dtype=bool)
    for structure_deg, bounded in ((3.0, True), (0.0, False)):
        pressure, residual = _steps_with_structure(structure_deg)
        model = noise.estimate(residual, scored, RATE_HZ)
        got = noise_bound.bounded_order(model, residual, model.detrend(residual), scored, pressure, RATE_HZ,
                                        finger)  # type: ignore[arg-type]
        if bounded:
            assert model.order > 2, model.order
            assert 1 <= got.order <= 2, got.order
            assert got.innovation_std_deg < 0.12
        else:
            assert got is model


def _steps_with_creep(creep_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """The steps and AR(1) noise of _steps_with_structure, plus a creep after each step: the
    angle goes on moving towards `creep_deg` times the step's size (in units of 80 kPa) with a
    time constant of 1.5 s, far slower than the finger's own settling (0.1 s)."""
    pressure, noise = _steps_with_structure(0.0)
    step_kpa = np.diff(pressure, prepend=pressure[0])
    creep = np.zeros(pressure.size)
    decay = np.exp(-1.0 / (1.5 * RATE_HZ))
    target = 0.0
    for i in range(1, pressure.size):
        target += creep_deg * step_kpa[i] / 80.0
        creep[i] = target + (creep[i - 1] - target) * decay
    return pressure, noise + creep


def test_the_noise_at_rest_is_measured_about_a_line_so_that_creep_is_not_noise() -> None:
    """Creep under a held command moves the angle after the finger has settled: about each
    stretch's mean it would count as the sensor's noise (and a stand-in model's misfit would
    stand within the noise so measured); about each stretch's line the noise is the sensor's,
    with creep or without."""
    from types import SimpleNamespace

    from hand_service.diagnose.residual import noise_bound

    finger = SimpleNamespace(prbm=SimpleNamespace(inertia_kgm2=1e-5, damping_nms_per_rad=0.05,
                                                  stiffness_nm_per_rad=0.5))  # decays in 0.1 s
    noise_std_deg = 0.1
    for creep_deg in (3.0, 0.0):
        pressure, residual = _steps_with_creep(creep_deg)
        scored = np.ones(residual.size, dtype=bool)
        got = noise_bound.bound(residual, residual, scored, pressure, RATE_HZ, finger)  # type: ignore[arg-type]
        about_mean = noise_bound.rest_noise(residual, scored, pressure, RATE_HZ, finger)  # type: ignore[arg-type]
        assert got is not None and about_mean is not None
        assert abs(got.rest_std_deg / noise_std_deg - 1.0) < 0.15, got.rest_std_deg
        if creep_deg:
            assert float(np.std(about_mean)) > 1.5 * noise_std_deg, float(np.std(about_mean))
