"""Simulated lab trials, recorded as docs/formats.md CSVs: what `identify` and `calibrate` read.

- `release_trial`: push the tip to an offset, hold it, release it at a random instant
  between two samples, record the free oscillation (the LDM experiment, docs/physics.md §2).
- `pressure_sweep`: a slow, smooth pressure sweep 0 → p_max → 0 with the measured
  chamber pressure (for `calibrate gain`).
- `valve_steps`: pressure steps with the measured chamber pressure (for `calibrate valve`:
  the valve's lag and dead time).
- `sensor_pairs`: the flex sensor's mV against reference angles (for `calibrate sensor`).

Every trial is simulated by the C simulator with the profile's noise and ADC, and is
deterministic for its seed. The recorded `angle_deg` is the sensor's mV through the
lab's calibration (`SensorMap`), as a recorder would write it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from hand_service.config.profile import FingerProfile
from hand_service.recording import write_recording
from hand_service.simulator import Simulator, profile_sim_finger
from hand_service.version import software_version


@dataclass(frozen=True)
class SensorMap:
    """The lab's mV → deg calibration: angle_deg = gain·mV + offset."""

    gain_deg_per_mv: float
    offset_deg: float

    @classmethod
    def of(cls, finger: FingerProfile) -> SensorMap:
        return cls(finger.sensor_gain_deg_per_mv, finger.sensor_offset_deg)

    def angle_deg(self, sensor_mv: np.ndarray) -> np.ndarray:
        return self.gain_deg_per_mv * np.asarray(sensor_mv) + self.offset_deg


@dataclass
class Trial:
    """One simulated recording: its columns (docs/formats.md names) and its provenance."""

    kind: str
    finger: str
    columns: dict[str, np.ndarray]
    metadata: dict[str, Any] = field(default_factory=dict)

    def write(self, path: str | Path) -> Path:
        write_recording(path, self.columns, self.metadata, digits=8)
        return Path(path)


def _metadata(kind: str, finger: FingerProfile, rate_hz: float, seed: int,
              extra: Mapping[str, Any]) -> dict[str, Any]:
    return {"finger": finger.name, "sample_rate_hz": f"{rate_hz:g}", "trial": kind,
            "source": "simulated", "profile": finger.model.source, "simulator_seed": seed,
            "software": software_version(), **extra}


def release_trial(finger: FingerProfile, simulation: Mapping[str, Any], offset_deg: float,
                  seed: int, rate_hz: float = 100.0, hold_s: float = 1.0, decay_s: float = 4.0,
                  oversample: int = 10, sensor_map: SensorMap | None = None) -> Trial:
    """Hold the finger at offset_deg for hold_s, release it, record decay_s of free motion.

    The simulator runs `oversample` times faster than the recording, so the release falls
    at a random instant between two recorded samples, as it does by hand.
    """
    sensor_map = sensor_map or SensorMap.of(finger)
    rng = np.random.default_rng(seed)
    fast_hz = rate_hz * oversample
    substeps = max(1, math.ceil(simulation["substeps"] / oversample))
    sim = Simulator([profile_sim_finger(finger, dict(simulation))], sample_rate_hz=fast_hz,
                    substeps=substeps, seed=seed)
    n_samples = round((hold_s + decay_s) * rate_hz)
    release_tick = round(hold_s * rate_hz) * oversample + int(rng.integers(0, oversample))
    mv = np.empty(n_samples)
    sim.set_state(0, offset_deg)
    sim.sample()
    mv[0] = sim.outputs.sensor_mv[0]
    for tick in range(1, n_samples * oversample - oversample + 1):
        sim.step()
        held = tick <= release_tick
        if held:
            sim.set_state(0, offset_deg)
        if tick % oversample == 0:
            if held:
                sim.sample()
            mv[tick // oversample] = sim.outputs.sensor_mv[0]
    t = np.arange(n_samples) / rate_hz
    columns = {"t": t, "pressure_kpa": np.zeros(n_samples), "angle_deg": sensor_map.angle_deg(mv),
               "sensor_mv": mv}
    meta = _metadata("release", finger, rate_hz, seed,
                     {"offset_deg": f"{offset_deg:.6g}", "release_s": f"{release_tick / fast_hz:.6g}"})
    return Trial("release", finger.name, columns, meta)


def release_trials(finger: FingerProfile, simulation: Mapping[str, Any], count: int, seed: int,
                   offset_range_deg: tuple[float, float] = (25.0, 40.0), **options: Any) -> list[Trial]:
    """`count` releases from offsets drawn in offset_range_deg, each with its own seed."""
    rng = np.random.default_rng(seed)
    offsets = rng.uniform(*offset_range_deg, size=count)
    seeds = rng.integers(0, 2**31, size=count)
    return [release_trial(finger, simulation, float(o), int(s), **options)
            for o, s in zip(offsets, seeds, strict=True)]


def _run(finger: FingerProfile, simulation: Mapping[str, Any], command_kpa: np.ndarray, rate_hz: float,
         seed: int, sensor_map: SensorMap) -> dict[str, np.ndarray]:
    """Drive one simulated finger with a command series; the recorded columns."""
    sim = Simulator([profile_sim_finger(finger, dict(simulation))], sample_rate_hz=rate_hz,
                    substeps=simulation["substeps"], seed=seed)
    n = command_kpa.size
    mv, meas = np.empty(n), np.empty(n)
    for k in range(n):
        mv[k] = sim.outputs.sensor_mv[0]
        meas[k] = sim.outputs.pressure_meas_kpa[0]
        sim.command_kpa[0] = command_kpa[k]
        sim.step()
    return {"t": np.arange(n) / rate_hz, "pressure_kpa": command_kpa.copy(), "pressure_meas_kpa": meas,
            "angle_deg": sensor_map.angle_deg(mv), "sensor_mv": mv}


def pressure_sweep(finger: FingerProfile, simulation: Mapping[str, Any], seed: int,
                   max_kpa: float | None = None, period_s: float = 20.0, rate_hz: float = 100.0,
                   sensor_map: SensorMap | None = None) -> Trial:
    """A raised-cosine sweep 0 → max_kpa → 0 (default: the finger's pressure limit). It
    starts and ends with zero slope, so it excites no ringing; it is slow next to the
    finger and the valve, so the finger stays near equilibrium."""
    max_kpa = finger.pressure_max_kpa if max_kpa is None else max_kpa
    n = round(period_s * rate_hz) + 1
    t = np.arange(n) / rate_hz
    command = 0.5 * max_kpa * (1.0 - np.cos(2.0 * math.pi * t / period_s))
    columns = _run(finger, simulation, command, rate_hz, seed, sensor_map or SensorMap.of(finger))
    meta = _metadata("pressure_sweep", finger, rate_hz, seed, {"max_kpa": f"{max_kpa:g}",
                                                                "period_s": f"{period_s:g}"})
    return Trial("pressure_sweep", finger.name, columns, meta)


def valve_steps(finger: FingerProfile, simulation: Mapping[str, Any], seed: int,
                levels_kpa: tuple[float, ...] | None = None, step_s: float = 0.5, rate_hz: float = 100.0,
                sensor_map: SensorMap | None = None) -> Trial:
    """Pressure steps between levels (default 0, 40 %, 80 %, 20 %, 60 % of the limit and
    back to 0), each held step_s, with the measured chamber pressure."""
    if levels_kpa is None:
        levels_kpa = tuple(f * finger.pressure_max_kpa for f in (0.0, 0.4, 0.8, 0.2, 0.6, 0.0))
    per_step = round(step_s * rate_hz)
    command = np.repeat(np.asarray(levels_kpa, dtype=float), per_step)
    columns = _run(finger, simulation, command, rate_hz, seed, sensor_map or SensorMap.of(finger))
    meta = _metadata("valve_steps", finger, rate_hz, seed, {"step_s": f"{step_s:g}"})
    return Trial("valve_steps", finger.name, columns, meta)


def sensor_pairs(finger: FingerProfile, simulation: Mapping[str, Any], seed: int,
                 angles_deg: np.ndarray | None = None, reference_noise_deg: float = 0.2,
                 readings_per_angle: int = 1) -> Trial:
    """The finger held at known angles (default 0 to 150° every 10°): the sensor's mV
    against a reference angle (a protractor or camera, with its own error)."""
    angles = np.arange(0.0, 151.0, 10.0) if angles_deg is None else np.asarray(angles_deg, dtype=float)
    sim = Simulator([profile_sim_finger(finger, dict(simulation))], seed=seed)
    rng = np.random.default_rng(seed)
    mv, reference = [], []
    for angle in angles:
        for _ in range(readings_per_angle):
            sim.set_state(0, float(angle))
            sim.sample()
            mv.append(sim.outputs.sensor_mv[0])
            reference.append(angle + reference_noise_deg * rng.standard_normal())
    n = len(mv)
    columns = {"sensor_mv": np.array(mv), "angle_deg": np.array(reference),
               "finger": np.array([finger.name] * n)}
    meta = {"trial": "sensor_pairs", "source": "simulated", "profile": finger.model.source,
            "simulator_seed": seed, "reference_noise_deg": reference_noise_deg,
            "software": software_version()}
    return Trial("sensor_pairs", finger.name, columns, meta)


__all__ = ["SensorMap", "Trial", "pressure_sweep", "release_trial", "release_trials", "sensor_pairs",
           "valve_steps"]
