"""The lab's `diagnose` on the mismatched plant: what the mission's flow gives the controller.

A lab identifies its hand (`calibrate sensor`, `calibrate gain`: mismatch.identify_on_plant),
records a free finger under pressure steps (`step_command_kpa`) with the board's measured
chamber pressure, fits its valve on that recording (`calibrate valve`), runs `diagnose` on
it with that model, and writes the refitted model with the effects found into the model file (`diagnose
--write-model`, Diagnosis.refit_model); the controller then runs that model. Here the
recording is made on the pinch's mismatched plant (hand_service.pinch.mismatch: the
stiffening, the hysteresis, the board's valves and the bowed sensor; the moving contact
point does not act on a free finger), read through the lab's calibrated sensor map, and
`diagnose` runs through its Python API (hand_service.diagnose.engine.diagnose), searching
also for the effects it leaves out by default that this plant has (`SEARCH`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hand_service.config.profile import FingerProfile, Profile
from hand_service.diagnose.engine import diagnose
from hand_service.diagnose.report.diagnosis import Diagnosis
from hand_service.identification.calibration import fit_valve
from hand_service.pinch.mismatch import PAPER_MISMATCH, BoardValves, Hysteresis, Mismatch, ValveLag
from hand_service.recording import Recording
from rtcore import Effects, Prbm
from rtcore.motion import FingerMotions
from rtcore.sim import SimFinger

# The mismatched plant with valves that vent as fast as they fill: a lag within diagnose's library.
EVEN_VALVES = dataclasses.replace(PAPER_MISMATCH, valves=BoardValves(vent_over_fill=1.0))
# asked by name: the stiffening and the vent lag beyond diagnose's default search, hysteresis
# fitted whatever its screen says (search/admission.py)
SEARCH = ("pressure_stiffening", "hysteresis", "valve_vent_lag")
STEP_LEVELS = (0.0, 0.4, 0.8, 0.2, 0.6, 0.0, 0.7, 0.3, 0.9, 0.1, 0.5, 0.0)  # shares of the limit
STEP_S = 2.0
RATE_HZ = 100.0
SUBSTEPS = 10


def step_command_kpa(finger: FingerProfile, rate_hz: float = RATE_HZ, step_s: float = STEP_S) -> np.ndarray:
    """Pressure steps up and down between shares of the finger's limit (STEP_LEVELS), each
    held step_s: every level met from above and from below, so a loop in the angle shows."""
    levels = np.asarray(STEP_LEVELS) * finger.pressure_max_kpa
    return np.repeat(levels, round(step_s * rate_hz))


def free_run(finger: FingerProfile, mismatch: Mismatch, command_kpa: np.ndarray,
             rate_hz: float = RATE_HZ) -> tuple[np.ndarray, np.ndarray]:
    """The true angle (deg) and chamber pressure (kPa) per sample of a free finger of the
    mismatched plant under a command held over each sample: rtcore's finger with the
    stiffening and hysteresis torques, behind the board's valves (or the profile's lag and
    dead time without them)."""
    m = finger.model
    board = mismatch.valves
    dt_s = 1.0 / (rate_hz * SUBSTEPS)
    effects = Effects() if board is not None else m.prbm("the lab's free run").effects
    prbm = Prbm(m.inertia_kgm2, m.damping_nms_per_rad, m.stiffness_nm_per_rad, m.pressure_gain_nm_per_kpa,
                m.lever_arm_m, dataclasses.replace(Effects(), valve_lag_tau_s=effects.valve_lag_tau_s))
    motion = FingerMotions([SimFinger(prbm)])
    # the dead time is the pipe's (with the board's valves: theirs, in ValveLag)
    delay = round(effects.dead_time_s / dt_s) if board is None else 0
    valves = None if board is None else ValveLag(board, np.array([board.fill_tau_of(finger.name)]), dt_s)
    pipe = np.zeros(delay + 1)
    hysteresis = Hysteresis(math.radians(mismatch.hysteresis_deg), (1,))
    stiffness = np.array([m.stiffness_nm_per_rad])
    angle_deg, chamber_kpa = np.empty(command_kpa.size), np.empty(command_kpa.size)
    for i, command in enumerate(command_kpa):
        angle_deg[i], chamber_kpa[i] = math.degrees(float(motion.angle_rad[0])), float(motion.chamber_kpa[0])
        for k in range(SUBSTEPS):
            step = i * SUBSTEPS + k
            pipe[step % pipe.size] = command
            delayed = np.array([pipe[(step - delay) % pipe.size]])
            if valves is not None:
                delayed = valves.step(delayed)
            bend = motion.angle_rad[:1].copy()
            extra = (mismatch.stiffening_torque_nm(stiffness, bend, motion.chamber_kpa[:1])
                     + hysteresis.torque_nm(stiffness, bend))
            motion.advance(delayed, -extra, dt_s)
    return angle_deg, chamber_kpa


def recorded_deg(truth: FingerProfile, lab: FingerProfile, mismatch: Mismatch, angle_deg: np.ndarray,
                 noise_deg: float, rng: np.random.Generator) -> np.ndarray:
    """What the lab's recording says the angle was: the bowed sensor's mV (truth's map)
    read back through the lab's calibrated map."""
    mv = (mismatch.sensed_deg(angle_deg) + noise_deg * rng.standard_normal(angle_deg.size)
          - truth.sensor_offset_deg) / truth.sensor_gain_deg_per_mv
    return lab.sensor_gain_deg_per_mv * mv + lab.sensor_offset_deg


@dataclass
class LabDiagnosis:
    finger: str
    diagnosis: Diagnosis
    valve_lag_tau_s: float  # the lab's `calibrate valve` on the same recording
    dead_time_s: float
    valve_vent_tau_s: float = 0.0  # its lag while venting, where fitted apart (0: valve_lag's)

    def effects_said(self) -> str:
        """The effects diagnose named, as `name(param=value, ...)`, or "none"."""
        return ", ".join(f"{e.name}(" + ", ".join(f"{k}={v:.3g}" for k, v in e.params.items()) + ")"
                         for e in self.diagnosis.effects) or "none"


def lab_diagnosis(truth: FingerProfile, lab: FingerProfile, mismatch: Mismatch,
                  rng: np.random.Generator, noise_deg: float, noise_kpa: float,
                  search: Sequence[str] = SEARCH, vent: bool = True) -> LabDiagnosis:
    """One finger's steps recording on the mismatched plant (the lab's calibrated angle and the
    board's measured chamber pressure), the lab's `calibrate valve` fit on it written into the
    model's valve_lag and dead_time (with `vent`, the lag while venting fitted apart too, over
    every step, as `calibrate valve --vent`: valve_vent_lag), then `diagnose` on it with that
    model."""
    command = step_command_kpa(truth)
    true_deg, chamber_kpa = free_run(truth, mismatch, command)
    angle = recorded_deg(truth, lab, mismatch, true_deg, noise_deg, rng)
    measured_kpa = chamber_kpa + noise_kpa * rng.standard_normal(command.size)
    t_s = np.arange(command.size) / RATE_HZ
    valve = fit_valve(Recording(Path(f"{truth.name}_steps.csv"), t_s, command, angle,
                                {"pressure_meas_kpa": measured_kpa}), vent=vent)
    model = lab.model.with_changes(effects={**lab.model.effects, **valve.effects()})
    result = diagnose(model, t_s, command, angle, RATE_HZ, also=tuple(search))
    return LabDiagnosis(truth.name, result, valve.tau_s, valve.delay_s, valve.vent_tau_s)


def diagnosed_controller(truth: Profile, controller: Profile, mismatch: Mismatch, seed: int,
                         fingers: Sequence[str], search: Sequence[str] = SEARCH, vent: bool = True
                         ) -> tuple[Profile, list[LabDiagnosis]]:
    """The controller after the lab's valve calibration and diagnose on each named finger:
    that finger's model replaced by what `diagnose --write-model` writes (the refit k, B, N
    and the effects found, beside the calibrated valve), with the force estimate carrying a
    loop diagnose names (control.force_estimate_hysteresis). Returns it and each finger's
    diagnosis."""
    rng = np.random.default_rng(seed)
    noise_deg = float(truth.simulation["sensor_noise_deg"])
    noise_kpa = float(truth.simulation["pressure_noise_kpa"])
    by_name = {f.name: f for f in controller.fingers}
    done = []
    for name in fingers:
        lab = by_name[name]
        found = lab_diagnosis(truth.finger(name), lab, mismatch, rng, noise_deg, noise_kpa, search, vent)
        done.append(found)
        by_name[name] = dataclasses.replace(lab, model=found.diagnosis.refit_model())
    control = dataclasses.replace(controller.control, force_estimate_hysteresis=True)
    return dataclasses.replace(controller, control=control,
                               fingers=[by_name[f.name] for f in controller.fingers]), done
