"""The force estimate's span: the lever arm that makes a known load read as itself."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from hand_service.cli import main
from hand_service.config.profile import DEFAULT_PROFILE, load_profile
from hand_service.identification.span import (
    MIN_LOAD_N,
    WHOLE_PERIODS_TOLERANCE,
    apply_span,
    span_lever,
    sweep_periods,
)
from hand_service.identification.trials import Trial


def _sweeps(scale: float, load_n: float) -> tuple[np.ndarray, np.ndarray]:
    """An unloaded sweep's estimate (an offset and a loop that averages out over whole
    periods) and the loaded one, reading the load times scale on top of it."""
    phase = np.linspace(0.0, 4.0 * np.pi, 800, endpoint=False)
    unloaded = 0.03 + 0.1 * np.sign(np.cos(phase))
    return unloaded, unloaded + scale * load_n


@pytest.mark.parametrize("scale", [1.14, 0.95, 1.05 * 1.14])
def test_the_span_scales_the_lever_so_the_load_reads_as_itself(scale: float) -> None:
    unloaded, loaded = _sweeps(scale, 0.6)
    span = span_lever("index", 0.05, unloaded, loaded, 0.6)
    assert span.scale == pytest.approx(scale, rel=1e-9)
    assert span.lever_after_m == pytest.approx(0.05 * scale, rel=1e-9)
    # the estimate is a torque over the lever: over r·s the load reads as itself
    assert (loaded.mean() - unloaded.mean()) * 0.05 / span.lever_after_m == pytest.approx(0.6, rel=1e-9)


def test_the_span_writes_only_its_fingers_lever() -> None:
    truth = load_profile(None)
    r_m = truth.finger("index").model.lever_arm_m
    unloaded, loaded = _sweeps(1.1, 0.5)
    spanned = apply_span(truth, span_lever("index", r_m, unloaded, loaded, 0.5))
    assert spanned.finger("index").model.lever_arm_m == pytest.approx(1.1 * r_m, rel=1e-9)
    assert spanned.finger("thumb").model == truth.finger("thumb").model


def test_the_span_refuses_what_it_cannot_read() -> None:
    unloaded, loaded = _sweeps(1.1, 0.5)
    with pytest.raises(ValueError, match="too small"):
        span_lever("index", 0.05, unloaded, loaded, 0.5 * MIN_LOAD_N)
    with pytest.raises(ValueError, match="outside"):
        span_lever("index", 0.05, unloaded, unloaded + 0.1, 0.5)  # read a fifth of the load
    with pytest.raises(ValueError, match="non-finite"):
        span_lever("index", 0.05, np.full(10, np.nan), loaded, 0.5)
    with pytest.raises(ValueError, match="both sweeps"):
        span_lever("index", 0.05, np.array([]), loaded, 0.5)


SWEEP_SAMPLES = 800
ANGLE_NOISE_DEG = 0.3
PRESSURE_NOISE_KPA = 0.5


def _sweep_file(path: Path, load_n: float, contact_lever_m: float, seed: int,
                samples: int = SWEEP_SAMPLES) -> Path:
    """A recorded sweep of the true index, 75° to 85° and back twice (over SWEEP_SAMPLES;
    4 s a sweep at 100 Hz), static (N p = k θ + r' F) with the load acting at
    contact_lever_m, ANGLE_NOISE_DEG and PRESSURE_NOISE_KPA of noise, its own draw (seed)."""
    true = load_profile(None).finger("index").model
    rng = np.random.default_rng(seed)
    t_s = np.arange(samples) / 100.0
    angle_deg = 80.0 + 5.0 * np.sin(2.0 * np.pi * t_s / 4.0)
    chamber_kpa = ((true.stiffness_nm_per_rad * np.radians(angle_deg) + contact_lever_m * load_n)
                   / true.pressure_gain_nm_per_kpa)
    noisy_deg = angle_deg + ANGLE_NOISE_DEG * rng.standard_normal(t_s.size)
    columns = {"t": t_s, "pressure_kpa": chamber_kpa, "angle_deg": noisy_deg,
               "pressure_meas_kpa": chamber_kpa + PRESSURE_NOISE_KPA * rng.standard_normal(t_s.size)}
    return Trial("span", "index", columns, {"finger": "index"}).write(path)


def _scale_sd(load_n: float) -> float:
    """The span's standard deviation from the sweeps' noise: a sample's estimate errs by
    (N·dp, k·dθ)/r in quadrature, and the span is the difference of two means over
    SWEEP_SAMPLES samples of independent draws, over the load."""
    true = load_profile(None).finger("index").model
    sample_n = float(np.hypot(true.pressure_gain_nm_per_kpa * PRESSURE_NOISE_KPA,
                              true.stiffness_nm_per_rad * np.radians(ANGLE_NOISE_DEG))) / true.lever_arm_m
    return sample_n * float(np.sqrt(2.0 / SWEEP_SAMPLES)) / load_n


def test_calibrate_span_writes_the_lever_back(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    r_m = load_profile(None).finger("index").model.lever_arm_m
    free = _sweep_file(tmp_path / "free.csv", 0.0, 1.14 * r_m, seed=5)
    loaded = _sweep_file(tmp_path / "loaded.csv", 0.6, 1.14 * r_m, seed=6)
    tolerance = 4.0 * _scale_sd(0.6)  # 0.044 here: four standard deviations
    mine = tmp_path / "mine.yaml"
    mine.write_text(DEFAULT_PROFILE.read_text())
    out = tmp_path / "span.json"
    assert main(["calibrate", "span", str(free), str(loaded), "--load-n", "0.6", "--model", str(mine),
                 "--finger", "index", "--json", str(out), "--update-profile", str(mine)]) == 0
    data = json.loads(out.read_text())
    assert data["scale"] == pytest.approx(1.14, abs=tolerance)
    assert data["scale"] != pytest.approx(1.14, abs=1e-6)  # the draws differ: noise is left in the span
    spanned_m = load_profile(mine).finger("index").model.lever_arm_m
    assert spanned_m == pytest.approx(data["scale"] * r_m, rel=1e-6)
    assert "| read per N of load |" in capsys.readouterr().out
    assert main(["calibrate", "span", str(free), str(loaded), "--load-n", "0.001", "--model", str(mine),
                 "--finger", "index"]) == 2


@pytest.mark.parametrize("periods", [1.0, 2.0, 2.3, 2.5, 3.0])
def test_the_sweeps_periods_are_counted_through_the_noise(periods: float) -> None:
    rng = np.random.default_rng(3)
    t_s = np.arange(round(periods * 400)) / 100.0
    noise_deg = ANGLE_NOISE_DEG * rng.standard_normal(t_s.size)
    angle_deg = 80.0 + 5.0 * np.sin(2.0 * np.pi * t_s / 4.0 + 0.7) + noise_deg
    counted, period_s = sweep_periods(t_s, angle_deg)
    assert counted == pytest.approx(periods, abs=0.2 * WHOLE_PERIODS_TOLERANCE)
    assert period_s == pytest.approx(4.0, rel=0.02)


def test_less_than_one_sweep_is_counted_as_less() -> None:
    t_s = np.arange(240) / 100.0  # 0.6 of a 4 s sweep
    counted, _ = sweep_periods(t_s, 80.0 + 5.0 * np.sin(2.0 * np.pi * t_s / 4.0 + 0.7))
    assert counted < 1.0 - 2.0 * WHOLE_PERIODS_TOLERANCE


def test_calibrate_span_refuses_a_part_sweep(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    r_m = load_profile(None).finger("index").model.lever_arm_m
    free = _sweep_file(tmp_path / "free.csv", 0.0, r_m, seed=5)
    # 2.25 sweeps
    loaded = _sweep_file(tmp_path / "loaded.csv", 0.6, r_m, seed=6, samples=SWEEP_SAMPLES + 100)
    mine = tmp_path / "mine.yaml"
    mine.write_text(DEFAULT_PROFILE.read_text())
    assert main(["calibrate", "span", str(free), str(loaded), "--load-n", "0.6", "--model", str(mine),
                 "--finger", "index"]) == 2
    said = capsys.readouterr().err.strip().splitlines()
    assert len(said) == 1
    assert "loaded.csv: the sweep covers 2.25 periods of 4 s, not a whole number" in said[0]
