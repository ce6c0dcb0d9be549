"""Impedance mode against a slow push: the finger's measured stiffness and its set value.

One finger of a profile, the truth's PRBM with its valve lag and dead time, in closed
loop with the C step in impedance mode about a fixed angle reference. A stiff contact
(a wall on the force point) comes down on the finger slowly, from beyond the reference
to well inside it; the measured stiffness is the slope of the true contact force
against the true angle (N per deg), by least squares, once the wall is ONSET_DEG
inside the reference (at first contact the force is as small as its noise, and a
contact that only pushes rectifies that noise into a mean force).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

import rtcore
from hand_service.config.effects import effect_value
from hand_service.config.profile import Profile

WALL_STIFFNESS_N_PER_M = 5000.0
SUBSTEPS = 10
ONSET_DEG = 5.0


@dataclass
class PushResult:
    set_stiffness_n_per_deg: float
    measured_stiffness_n_per_deg: float
    angle_deg: np.ndarray  # true angle, one per control tick in contact
    force_n: np.ndarray  # true contact force, likewise

    @property
    def error_ratio(self) -> float:
        return self.measured_stiffness_n_per_deg / self.set_stiffness_n_per_deg - 1.0


def slow_push(profile: Profile, finger: str, stiffness_n_per_deg: float, damping_n_s_per_deg: float,
              reference_deg: float = 40.0, push_deg: float = 20.0, push_s: float = 20.0,
              seed: int = 1) -> PushResult:
    f = profile.finger(finger)
    config = f.rtcore_config(profile.control)
    hand = rtcore.Hand(rtcore.HandConfig([config], sample_rate_hz=profile.control.rate_hz))
    m = f.model
    dt_s = 1.0 / (profile.control.rate_hz * SUBSTEPS)
    tau_s = max(effect_value(m.effects, "valve_lag"), 1e-4)
    delay = round(effect_value(m.effects, "dead_time") / dt_s)
    pipe = np.zeros(delay + 1)
    rng = np.random.default_rng(seed)
    noise_deg = float(profile.simulation["sensor_noise_deg"])
    noise_kpa = float(profile.simulation["pressure_noise_kpa"])
    hand.inputs.mode[0] = rtcore.MODE_IMPEDANCE
    hand.inputs.angle_ref_deg[0] = reference_deg
    hand.inputs.impedance_stiffness_n_per_deg[0] = stiffness_n_per_deg
    hand.inputs.impedance_damping_n_s_per_deg[0] = damping_n_s_per_deg
    settle_s = 2.0
    ticks = round((settle_s + push_s + 1.0) * profile.control.rate_hz)
    angle = velocity = chamber = 0.0
    command = 0.0
    wall_start_deg = reference_deg + 3.0
    angles, forces = [], []
    for tick in range(ticks):
        t_s = tick / profile.control.rate_hz
        progress = min(max((t_s - settle_s) / push_s, 0.0), 1.0)
        wall_rad = np.radians(wall_start_deg - (push_deg + 3.0) * progress)
        angle_deg = np.degrees(angle) + noise_deg * rng.standard_normal()
        hand.inputs.sensor_mv[0] = (angle_deg - f.sensor_offset_deg) / f.sensor_gain_deg_per_mv
        hand.inputs.pressure_meas_kpa[0] = chamber + noise_kpa * rng.standard_normal()
        hand.step()
        command = float(hand.outputs.pressure_cmd_kpa[0])
        force = 0.0
        for k in range(SUBSTEPS):
            pipe[(tick * SUBSTEPS + k) % pipe.size] = command
            delayed = pipe[(tick * SUBSTEPS + k - delay) % pipe.size]
            chamber += (delayed - chamber) * (1.0 - np.exp(-dt_s / tau_s))
            force = max(WALL_STIFFNESS_N_PER_M * m.lever_arm_m * (angle - wall_rad), 0.0)
            torque = (m.pressure_gain_nm_per_kpa * chamber - m.stiffness_nm_per_rad * angle
                      - m.damping_nms_per_rad * velocity - m.lever_arm_m * force)
            velocity += dt_s * torque / m.inertia_kgm2
            angle += dt_s * velocity
        if np.degrees(wall_rad) < reference_deg - ONSET_DEG and force > 0.0:
            angles.append(np.degrees(angle))
            forces.append(force)
    a, fo = np.array(angles), np.array(forces)
    if a.size < 10:
        raise ValueError("the wall never pressed on the finger")
    slope = -np.polyfit(a, fo, 1)[0]  # force rises as the angle falls below the reference
    return PushResult(stiffness_n_per_deg, float(slope), a, fo)
