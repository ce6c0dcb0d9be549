"""A lab session on the simulated hand: every model parameter the controller will use is
measured with the project's own tools on simulated recordings, never copied from the
simulator's truth.

Per finger, in the order a lab would go:

1. `calibrate sensor` on mV / reference-angle pairs → the sensor map the recorder and the
   controller use;
2. `identify` on push-and-release trials, recorded through that map → k and B (and the
   paper's two-peak recipe on the same files, for Table 1);
3. `calibrate valve` on pressure steps with the measured chamber pressure → the valve lag
   and dead time the feedforward compensates;
4. `calibrate gain` on a slow pressure sweep, with the identified k → N.

What the lab takes as known are the weighed and measured mass, length and γ (hence A and
the lever arm r, docs/physics.md §1), and the controller settings of the profile (gains,
filters, limits).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from hand_service.config.model import FingerModel
from hand_service.config.profile import FingerProfile, Profile
from hand_service.identification import trials
from hand_service.identification.calibration import (
    GainFit,
    SensorFit,
    ValveFit,
    fit_pressure_gain,
    fit_sensor_map,
    fit_valve,
)
from hand_service.identification.identify import IdentifyResult, identify_recordings
from hand_service.recording import read_recording


@dataclass
class MeasuredFinger:
    name: str
    sensor: SensorFit
    identified: IdentifyResult  # default method
    two_peak: IdentifyResult  # the paper's recipe on the same trials
    valve: ValveFit
    gain: GainFit
    model: FingerModel  # what the controller gets

    def to_json(self) -> dict[str, Any]:
        return {"stiffness_nm_per_rad": self.model.stiffness_nm_per_rad,
                "damping_nms_per_rad": self.model.damping_nms_per_rad,
                "pressure_gain_nm_per_kpa": self.model.pressure_gain_nm_per_kpa,
                "inertia_kgm2": self.model.inertia_kgm2, "lever_arm_m": self.model.lever_arm_m,
                "valve_lag_tau_s": self.valve.tau_s, "dead_time_s": self.valve.delay_s,
                "sensor_gain_deg_per_mv": self.sensor.gain_deg_per_mv,
                "sensor_offset_deg": self.sensor.offset_deg, "gain_r_squared": self.gain.r_squared,
                "sensor_r_squared": self.sensor.r_squared}


def geometry_model(finger: FingerProfile) -> FingerModel:
    """What the lab knows before measuring: the finger's name, mass, length, γ, A and r."""
    m = finger.model
    return FingerModel(inertia_kgm2=m.inertia_kgm2, lever_arm_m=m.lever_arm_m, finger=finger.name,
                       mass_kg=m.mass_kg, length_m=m.length_m, gamma=m.gamma, source=f"{m.source} (geometry)")


def measure_finger(finger: FingerProfile, simulation: dict[str, Any], workdir: Path, n_trials: int,
                   seed: int, progress: Callable[[str], None] | None = None) -> MeasuredFinger:
    """Simulate the finger's lab session into workdir and measure it (module docstring)."""
    seeds = np.random.SeedSequence([seed]).generate_state(4)
    name = finger.name
    say = progress or (lambda _: None)

    pairs_path = trials.sensor_pairs(finger, simulation, int(seeds[0]), readings_per_angle=5).write(
        workdir / f"{name}_pairs.csv")
    pairs = read_recording(pairs_path, required=("sensor_mv", "angle_deg"), min_duration_s=0.0)
    sensor = fit_sensor_map(pairs, name)[0]
    sensor_map = trials.SensorMap(sensor.gain_deg_per_mv, sensor.offset_deg)

    paths = [trial.write(workdir / f"{name}_release_{i:02d}.csv") for i, trial in enumerate(
        trials.release_trials(finger, simulation, n_trials, int(seeds[1]), sensor_map=sensor_map))]
    known = geometry_model(finger)
    identified = identify_recordings(paths, known, name, "fit")
    two_peak = identify_recordings(paths, known, name, "two-peak")
    say(f"{name}: sensor gain {sensor.gain_deg_per_mv:.5g} deg/mV (R² {sensor.r_squared:.5f}); "
        f"identify on {n_trials} releases: k = {identified.stiffness_nm_per_rad:.5g}, "
        f"B = {identified.damping_nms_per_rad:.4g}")

    valve_path = trials.valve_steps(finger, simulation, int(seeds[2]), sensor_map=sensor_map).write(
        workdir / f"{name}_valve.csv")
    valve = fit_valve(read_recording(valve_path))
    sweep_path = trials.pressure_sweep(finger, simulation, int(seeds[3]), sensor_map=sensor_map).write(
        workdir / f"{name}_sweep.csv")
    with_k = known.with_changes(stiffness_nm_per_rad=identified.stiffness_nm_per_rad)
    gain = fit_pressure_gain(read_recording(sweep_path), with_k)
    say(f"{name}: valve tau {1000 * valve.tau_s:.1f} ms, dead time {1000 * valve.delay_s:.1f} ms; "
        f"N = {gain.pressure_gain_nm_per_kpa:.5g} N·m/kPa (R² {gain.r_squared:.6f})")

    model = with_k.with_changes(damping_nms_per_rad=identified.damping_nms_per_rad,
                                pressure_gain_nm_per_kpa=gain.pressure_gain_nm_per_kpa,
                                effects=valve.effects(), source="measured")
    return MeasuredFinger(name, sensor, identified, two_peak, valve, gain, model)


def controller_profile(truth: Profile, measured: list[MeasuredFinger]) -> Profile:
    """The profile the controller runs with: the truth's settings (gains, filters, limits)
    and geometry, with every measured value in place of the truth's."""
    by_name = {m.name: m for m in measured}
    fingers = [dataclasses.replace(f, model=by_name[f.name].model,
                                   sensor_gain_deg_per_mv=by_name[f.name].sensor.gain_deg_per_mv,
                                   sensor_offset_deg=by_name[f.name].sensor.offset_deg)
               for f in truth.fingers]
    return dataclasses.replace(truth, fingers=fingers)


__all__ = ["MeasuredFinger", "controller_profile", "geometry_model", "measure_finger"]
