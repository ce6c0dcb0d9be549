"""The force estimate's tare: a free finger's estimate must read 0 N.

The Moore-Penrose estimate F = (N·p_eff − τ(θ) − stiffening − H·z) / r is affine in the
pressure gain N. A calibration error that leaves N/k off by e makes the estimate's slope
against the angle off by e·k/r (hand_service.pinch.bode.quasi_static_ratio): at K_max the
rendered stiffness moves by about 2·e, which no feedback on the estimate can see. A real
force-estimating hand tares its estimate where it knows the force: in free motion, before
contact. Here the tare holds the finger free (no contact) at the operating angle, averages
the controller's own estimate and the chamber pressure it used, and sets the N that makes
that mean estimate 0: N' = N − r·F̄ / p̄_eff. With k right or wrong, the tared model's N/k is
the finger's own at that angle (its secant torque per pressure), so only k's error is left:
the rendered stiffness K/(1 + e_k) instead of (K + (e_N − e_k)·2·K_max)/(1 + e_N). What acts
only under a force (a joint friction, a contact point that moves) a free hold cannot see.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from hand_service.config.model import FingerModel
from hand_service.config.profile import Profile
from hand_service.recording import Recording
from rtcore.reference_model import (
    effective_pressure,
    hysteresis_angle_update,
    hysteresis_torque,
    model_torque,
    stiffening_torque,
)

MIN_EFFECTIVE_KPA = 5.0  # below this the estimate hardly depends on N: nothing to tare on


@dataclass(frozen=True)
class Tare:
    """One finger's tare: the mean estimate and effective pressure over the free hold, N
    before and after."""

    finger: str
    estimate_n: float
    effective_kpa: float
    gain_before_nm_per_kpa: float
    gain_after_nm_per_kpa: float

    @property
    def gain_change_pct(self) -> float:
        return 100.0 * (self.gain_after_nm_per_kpa / self.gain_before_nm_per_kpa - 1.0)


def tare_gain(model: FingerModel, finger: str, estimate_n: np.ndarray, chamber_kpa: np.ndarray) -> Tare:
    """The N that zeroes the mean of a free hold's force estimate (estimate_n, N, made with
    `model`) at the chamber pressures it was made from (chamber_kpa, one per sample)."""
    estimate = np.asarray(estimate_n, dtype=float)
    chamber = np.asarray(chamber_kpa, dtype=float)
    if estimate.size == 0 or estimate.shape != chamber.shape:
        raise ValueError("the tare needs one chamber pressure per estimate, and at least one")
    if not (np.all(np.isfinite(estimate)) and np.all(np.isfinite(chamber))):
        raise ValueError("the tare's hold has a non-finite estimate or pressure")
    effects = model.prbm("the tare").effects
    effective_kpa = float(np.mean([effective_pressure(effects, float(p)) for p in chamber]))
    if effective_kpa < MIN_EFFECTIVE_KPA:
        raise ValueError(f"the tare's hold is at {effective_kpa:.2f} kPa effective pressure, under "
                         f"{MIN_EFFECTIVE_KPA:g} kPa: the estimate hardly depends on N there")
    mean_n = float(np.mean(estimate))
    lever_m = model.prbm("the tare").lever_arm_m
    gain = model.pressure_gain_nm_per_kpa
    return Tare(finger, mean_n, effective_kpa, gain, gain - lever_m * mean_n / effective_kpa)


@dataclass
class _LoopState:
    """The part of a finger's state the controller's Dahl copy keeps (reference_model.FingerState)."""

    angle_filt_deg: float = 0.0
    angle_ref_deg: float = 0.0
    velocity_ref_deg_per_s: float = 0.0
    creep_ref_deg: float = 0.0
    hysteresis_ref_z: float = 0.0
    hysteresis_ref_angle_deg: float = 0.0
    hysteresis_z: float = 0.0
    hysteresis_angle_deg: float = math.nan  # none seen yet


def recorded_estimate_n(recording: Recording, model: FingerModel, with_loop: bool = False) -> np.ndarray:
    """The controller's static force estimate (N) made again from a recording's angle and
    measured chamber pressure: (N·p_eff − τ(θ) − stiffening) / r, and H·z with_loop, z the
    Dahl state over the recorded angle, as control.force_estimate_hysteresis takes it."""
    measured = recording.optional("pressure_meas_kpa")
    if measured is None:
        raise ValueError(f"{recording.path}: the estimate needs the measured chamber pressure "
                         "(pressure_meas_kpa) in every sample")
    prbm = model.prbm("the recorded estimate")
    effects = prbm.effects
    loop = _LoopState()
    estimate = np.empty(len(recording.angle_deg))
    for i, (angle_deg, chamber_kpa) in enumerate(zip(recording.angle_deg, measured, strict=True)):
        angle_rad = float(np.radians(angle_deg))
        effective_kpa = effective_pressure(effects, float(chamber_kpa))
        torque = (model.pressure_gain_nm_per_kpa * effective_kpa
                  - stiffening_torque(prbm, angle_rad, effective_kpa) - model_torque(prbm, angle_rad, 0.0))
        if with_loop:
            loop.angle_filt_deg = float(angle_deg)
            hysteresis_angle_update(effects, loop)
            torque -= hysteresis_torque(effects, loop.hysteresis_z)
        estimate[i] = torque / prbm.lever_arm_m
    return estimate


def tare_from_recording(recording: Recording, model: FingerModel, finger: str,
                        with_loop: bool = False) -> Tare:
    """The tare from a recorded free hold (`hand-service calibrate tare`): the controller's
    static estimate made again from it (recorded_estimate_n), then tare_gain."""
    estimate = recorded_estimate_n(recording, model, with_loop)
    return tare_gain(model, finger, estimate, recording.optional("pressure_meas_kpa"))


def apply_tare(profile: Profile, tare: Tare) -> Profile:
    """The profile with that finger's N the tare's."""
    gain = tare.gain_after_nm_per_kpa
    fingers = [dataclasses.replace(f, model=f.model.with_changes(pressure_gain_nm_per_kpa=gain))
               if f.name == tare.finger else f for f in profile.fingers]
    return dataclasses.replace(profile, fingers=fingers)
