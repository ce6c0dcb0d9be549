"""A plant that is not the estimator: how the simulated pinch hand differs from the PRBM
the controller runs, on top of rtcore's finger simulator (no new library effect).

- Pressure stiffening: the silicone's spring k(p) = k (1 + c p / p_ref), applied as the
  external torque -k c (p / p_ref) θ on rtcore's finger (p the chamber pressure).
- A contact point that moves with the bend: the pad's force acts at r (1 + a θ) from the
  joint, not at the model's r; the tip's travel along the pinch axis stays r θ.
- A flex sensor with its own error: the true angle plus a bow b sin(π θ / θ_span) over
  the calibrated span, before the sensor's mV (its hysteresis-free part: what a linear
  calibration cannot remove).
- Rate-independent hysteresis of the silicone: one elastic-plastic (Prandtl) element in
  parallel with the spring, the torque k (θ − z) with z kept within h of θ (the play
  operator), at most k h: the angle against pressure runs a loop about 2 h wide whatever
  the speed (`Hysteresis`).
- The board's valves, not the controller's: a fill lag and a (slower) vent lag per finger
  and the board's dead time, where the controller's feedforward assumes the profile's
  30 ms lag and 5 ms dead time (`BoardValves`).

The controller keeps the PRBM: the lab's `calibrate sensor` and `calibrate gain` are run
again on this plant (`identify_on_plant`), as a lab would on its hand; the free releases
(zero pressure, no contact) that `identify` uses see only the sensor's bow, which the
recalibrated map carries. docs/replicate.md gives where each size comes from.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hand_service.config.profile import FingerProfile, Profile
from hand_service.identification.calibration import fit_pressure_gain, fit_sensor_map
from hand_service.identification.trials import Trial
from hand_service.recording import read_recording
from rtcore import Effects, Prbm
from rtcore.motion import FingerMotions
from rtcore.sim import SimFinger

SENSOR_SPAN_DEG = 150.0  # the calibrated span of `calibrate sensor`'s pairs (0 to 150 deg)


@dataclass(frozen=True)
class BoardValves:
    """The valve board's chamber dynamics as a first-order lag behind a dead time, the lag
    by direction: filling per finger, venting VENT_OVER_FILL times slower (docs/replicate.md)."""

    fill_tau_s: tuple[tuple[str, float], ...] = (("thumb", 0.034), ("index", 0.040), ("middle", 0.068),
                                                 ("ring", 0.036), ("little", 0.044))
    vent_over_fill: float = 4.0
    dead_time_s: float = 0.003

    def fill_tau_of(self, finger: str) -> float:
        return dict(self.fill_tau_s)[finger]


class ValveLag:
    """The board's valves over (n, 2) fingers: a dead time pipe and a lag that fills at one
    time constant and vents at another. `step` takes the command, returns the chamber."""

    def __init__(self, valves: BoardValves, fill_tau_s: np.ndarray, dt_s: float) -> None:
        self.fill_alpha = np.exp(-dt_s / fill_tau_s)
        self.vent_alpha = np.exp(-dt_s / (fill_tau_s * valves.vent_over_fill))
        self.chamber_kpa = np.zeros(fill_tau_s.shape)
        self._pipe = np.zeros((max(round(valves.dead_time_s / dt_s), 0) + 1, *fill_tau_s.shape))
        self._at = 0

    def step(self, command_kpa: np.ndarray) -> np.ndarray:
        self._pipe[self._at] = command_kpa
        self._at = (self._at + 1) % self._pipe.shape[0]
        delayed = self._pipe[self._at]  # the oldest: dead time's worth of substeps ago
        alpha = np.where(delayed > self.chamber_kpa, self.fill_alpha, self.vent_alpha)
        self.chamber_kpa = delayed + alpha * (self.chamber_kpa - delayed)
        return self.chamber_kpa


class Hysteresis:
    """The silicone's rate-independent hysteresis on (n, 2) fingers: a play operator z that
    stays within width_rad of the angle, and the torque k (θ − z) against the bend."""

    def __init__(self, width_rad: float, shape: tuple[int, ...]) -> None:
        self.width_rad = width_rad
        self.z_rad = np.zeros(shape)

    def torque_nm(self, stiffness_nm_per_rad: np.ndarray, angle_rad: np.ndarray) -> np.ndarray:
        """The element's torque (positive: opening) at this angle, the play updated to it."""
        self.z_rad = np.clip(self.z_rad, angle_rad - self.width_rad, angle_rad + self.width_rad)
        return stiffness_nm_per_rad * (angle_rad - self.z_rad)


@dataclass(frozen=True)
class Mismatch:
    stiffening: float = 0.0  # c: k(p) = k (1 + c p / p_ref)
    reference_kpa: float = 100.0
    lever_drift_per_rad: float = 0.0  # a: the pad's force acts at r (1 + a θ)
    sensor_bow_deg: float = 0.0  # b: the flex sensor reads θ + b sin(π θ / span)
    hysteresis_deg: float = 0.0  # h: the play operator's half-width
    valves: BoardValves | None = None  # None: the profile's valve, as the controller assumes

    def stiffening_torque_nm(self, stiffness_nm_per_rad: np.ndarray, angle_rad: np.ndarray,
                             chamber_kpa: np.ndarray) -> np.ndarray:
        """The spring's extra torque against the bend (positive: opening)."""
        return stiffness_nm_per_rad * self.stiffening * (chamber_kpa / self.reference_kpa) * angle_rad

    def contact_lever_m(self, lever_arm_m: np.ndarray, angle_rad: np.ndarray) -> np.ndarray:
        return lever_arm_m * (1.0 + self.lever_drift_per_rad * angle_rad)

    def sensed_deg(self, angle_deg: np.ndarray) -> np.ndarray:
        """What the flex sensor says the angle is (before its mV and noise)."""
        return angle_deg + self.sensor_bow_deg * np.sin(np.pi * np.asarray(angle_deg) / SENSOR_SPAN_DEG)


NONE = Mismatch()
# Sized in docs/replicate.md: c, a and h are assumptions of the order a soft finger shows;
# the sensor's bow is the size that brings the force estimate's error to the paper's; the
# valves are the board's pneumatics as the simulator's pneumatic plant measures them.
PAPER_MISMATCH = Mismatch(stiffening=0.01, lever_drift_per_rad=0.1, sensor_bow_deg=1.0, hysteresis_deg=0.5,
                          valves=BoardValves())
PLANTS = {"model": NONE, "mismatched": PAPER_MISMATCH}


def _sweep_trial(finger: FingerProfile, mismatch: Mismatch, rng: np.random.Generator, noise_deg: float,
                 rate_hz: float = 100.0, period_s: float = 20.0, substeps: int = 10) -> Trial:
    """`calibrate gain`'s slow sweep (hand_service.identification.trials.pressure_sweep)
    on this plant: rtcore's finger with the stiffening torque, no contact, the bowed sensor."""
    m = finger.model
    prbm = Prbm(m.inertia_kgm2, m.damping_nms_per_rad, m.stiffness_nm_per_rad, m.pressure_gain_nm_per_kpa,
                m.lever_arm_m, Effects())
    motion = FingerMotions([SimFinger(prbm)])
    n = round(period_s * rate_hz) + 1
    t = np.arange(n) / rate_hz
    command = 0.5 * finger.pressure_max_kpa * (1.0 - np.cos(2.0 * math.pi * t / period_s))
    angle_deg = np.empty(n)
    dt = 1.0 / (rate_hz * substeps)
    stiffness = np.array([m.stiffness_nm_per_rad])
    hysteresis = Hysteresis(math.radians(mismatch.hysteresis_deg), (1,))
    for i in range(n):
        angle_deg[i] = math.degrees(float(motion.angle_rad[0]))
        for _ in range(substeps):
            angle = motion.angle_rad[:1].copy()
            extra = (mismatch.stiffening_torque_nm(stiffness, angle, np.array([command[i]]))
                     + hysteresis.torque_nm(stiffness, angle))
            motion.advance(np.array([command[i]]), -extra, dt)
    read = mismatch.sensed_deg(angle_deg) + noise_deg * rng.standard_normal(n)
    return Trial("pressure_sweep", finger.name, {"t": t, "pressure_kpa": command, "angle_deg": read},
                 {"trial": "pressure_sweep", "source": "simulated (pinch mismatch)"})


def _pairs_trial(finger: FingerProfile, mismatch: Mismatch, rng: np.random.Generator, noise_deg: float,
                 reference_noise_deg: float = 0.2, readings_per_angle: int = 5) -> Trial:
    """`calibrate sensor`'s pairs (trials.sensor_pairs) with the bowed sensor."""
    angles = np.repeat(np.arange(0.0, SENSOR_SPAN_DEG + 1.0, 10.0), readings_per_angle)
    sensed = mismatch.sensed_deg(angles) + noise_deg * rng.standard_normal(angles.size)
    mv = (sensed - finger.sensor_offset_deg) / finger.sensor_gain_deg_per_mv
    reference = angles + reference_noise_deg * rng.standard_normal(angles.size)
    return Trial("sensor_pairs", finger.name, {"sensor_mv": mv, "angle_deg": reference},
                 {"trial": "sensor_pairs", "source": "simulated (pinch mismatch)", "finger": finger.name})


def identify_on_plant(truth: Profile, controller: Profile, mismatch: Mismatch, seed: int,
                      workdir: Path) -> Profile:
    """The controller's profile with its sensor map and pressure gain N measured again on
    the mismatched plant by the project's `calibrate sensor` and `calibrate gain` fits."""
    rng = np.random.default_rng(seed)
    noise_deg = float(truth.simulation["sensor_noise_deg"])
    by_name = {f.name: f for f in controller.fingers}
    fingers = []
    for finger in truth.fingers:
        mine = by_name[finger.name]
        pairs = _pairs_trial(finger, mismatch, rng, noise_deg)
        pairs_path = pairs.write(workdir / f"{finger.name}_pairs.csv")
        sensor = fit_sensor_map(read_recording(pairs_path, required=("sensor_mv", "angle_deg"),
                                               min_duration_s=0.0), finger.name)[0]
        sweep = _sweep_trial(finger, mismatch, rng, noise_deg)
        sweep_path = sweep.write(workdir / f"{finger.name}_sweep.csv")
        gain = fit_pressure_gain(read_recording(sweep_path), mine.model)
        model = mine.model.with_changes(pressure_gain_nm_per_kpa=gain.pressure_gain_nm_per_kpa)
        fingers.append(dataclasses.replace(mine, model=model, sensor_gain_deg_per_mv=sensor.gain_deg_per_mv,
                                           sensor_offset_deg=sensor.offset_deg))
    return dataclasses.replace(controller, fingers=fingers)
