"""A readable pure-Python implementation of exactly the C control step.

It exists to be read and to check the C core: the equivalence tests drive both with the
same random configurations and inputs and require agreement to 1e-9. The arithmetic is
written in the same order as csrc/ so the two round alike.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from rtcore import config as cfg
from rtcore.arrays import Inputs, Outputs, allocate
from rtcore.config import ConfigError, FingerConfig, HandConfig
from rtcore.reference_filter import Biquad, butter_sections, first_order_alpha
from rtcore.reference_model import (
    RAD_PER_DEG,
    STIFFENED_GAIN_FLOOR,
    creep_reference_update,
    deadzone_invert,
    effective_pressure,
    hysteresis_angle_update,
    hysteresis_reference_update,
    hysteresis_torque,
    model_stiffness,
    model_torque,
    model_torque_rate,
    stiffened_gain_share,
    stiffening_torque,
    valve_tau,
)

SANE_LIMIT = 1000000.0  # RTCORE_SANE_LIMIT
POSITION_REFERENCES = ("angle_ref_deg", "velocity_ref_deg_per_s", "accel_ref_deg_per_s2",
                       "jerk_ref_deg_per_s3")
REFERENCES = (*POSITION_REFERENCES, "force_ref_n", "pressure_ref_kpa")
IMPEDANCE_GAINS = ("impedance_stiffness_n_per_deg", "impedance_damping_n_s_per_deg")
IMPEDANCE_LEAD_MAX_SHARE = 0.25  # the C step's: impedance's lead at most this share of k


def usable(x: float) -> bool:
    return math.isfinite(x) and abs(x) <= SANE_LIMIT


# --- the PRBM with its effects: rtcore/reference_model.py ------------------------------

def position_feedforward(c: FingerConfig, s: FingerState) -> float:
    angle = s.angle_ref_deg * RAD_PER_DEG
    velocity = s.velocity_ref_deg_per_s * RAD_PER_DEG
    accel = s.accel_ref_deg_per_s2 * RAD_PER_DEG
    jerk = s.jerk_ref_deg_per_s3 * RAD_PER_DEG
    m = c.prbm
    share = stiffened_gain_share(m, angle)
    gain = m.pressure_gain_nm_per_kpa * share
    if c.feedforward == cfg.FF_DYNAMIC:
        torque = (m.inertia_kgm2 * accel + m.damping_nms_per_rad * velocity
                  + model_torque(m, angle, velocity))
        torque_rate = (m.inertia_kgm2 * jerk + m.damping_nms_per_rad * accel
                       + model_torque_rate(m, angle, velocity, accel))
    elif c.feedforward == cfg.FF_QUASI_STATIC:
        torque = model_torque(m, angle, 0.0)
        torque_rate = model_stiffness(m, angle) * velocity
    else:
        return 0.0
    if m.effects.creep_stiffness_ratio > 0.0:
        creep_rad = s.creep_ref_deg * RAD_PER_DEG
        branch = m.effects.creep_stiffness_ratio * m.stiffness_nm_per_rad
        torque += branch * (angle - creep_rad)
        torque_rate += branch * (velocity - (angle - creep_rad) / m.effects.creep_time_s)
    if m.effects.hysteresis_torque_nm > 0.0:  # z already led: no rate
        torque += m.effects.hysteresis_torque_nm * s.hysteresis_ref_z
    if m.effects.pressure_stiffening_gain > 0.0 and share > STIFFENED_GAIN_FLOOR:
        torque_rate += torque * stiffening_torque(m, 1.0, 1.0) * velocity / gain
    lead_s = valve_tau(m.effects, torque_rate) + m.effects.dead_time_s
    return deadzone_invert(m.effects, torque / gain) + lead_s * torque_rate / gain


def force_feedforward(c: FingerConfig, angle_rad: float, force_ref_n: float, hysteresis_z: float,
                      torque_rate_nm_per_s: float = 0.0) -> float:
    """N p = tau(th, 0) + H z + r F_n, with the lead (valve lag + dead time) on the torque's rate."""
    m = c.prbm
    torque = (model_torque(m, angle_rad, 0.0) + hysteresis_torque(m.effects, hysteresis_z)
              + m.lever_arm_m * force_ref_n)
    gain = m.pressure_gain_nm_per_kpa * stiffened_gain_share(m, angle_rad)
    lead_s = valve_tau(m.effects, torque_rate_nm_per_s) + m.effects.dead_time_s
    return deadzone_invert(m.effects, torque / gain) + lead_s * torque_rate_nm_per_s / gain


def force_normal(c: FingerConfig, chamber_kpa: float, angle_rad: float, velocity: float,
                 accel: float, hysteresis_z: float) -> float:
    """Signed normal force (J^T)+ (N p - tau - H z): F_n = (N p_eff - tau - H z) / r."""
    m = c.prbm
    effective_kpa = effective_pressure(m.effects, chamber_kpa)
    torque = (m.pressure_gain_nm_per_kpa * effective_kpa - stiffening_torque(m, angle_rad, effective_kpa)
              - hysteresis_torque(m.effects, hysteresis_z))
    if c.force_estimate_dynamic:
        torque -= (m.inertia_kgm2 * accel + m.damping_nms_per_rad * velocity
                   + model_torque(m, angle_rad, velocity))
    else:
        torque -= model_torque(m, angle_rad, 0.0)
    return torque / m.lever_arm_m


# --- limits and anti-windup ----------------------------------------------------------

def limit_command(c: FingerConfig, unsat: float, previous: float, dt_s: float, error: float,
                  integrator_old: float, integrator_new: float) -> tuple[float, float, int]:
    step = c.pressure_rate_max_kpa_per_s * dt_s
    lowest, highest = previous - step, previous + step
    command, integrator, flags = unsat, integrator_new, 0
    if command > c.pressure_max_kpa:
        command, flags = c.pressure_max_kpa, flags | cfg.FLAG_SATURATED
    elif command < c.pressure_min_kpa:
        command, flags = c.pressure_min_kpa, flags | cfg.FLAG_SATURATED
    if command > highest:
        command, flags = highest, flags | cfg.FLAG_RATE_LIMITED
    elif command < lowest:
        command, flags = lowest, flags | cfg.FLAG_RATE_LIMITED
    if (unsat > command and error > 0.0) or (unsat < command and error < 0.0):
        integrator, flags = integrator_old, flags | cfg.FLAG_INTEGRATOR_HELD
    integrator = min(max(integrator, -c.integrator_limit_kpa), c.integrator_limit_kpa)
    return command, integrator, flags


def clamp_symmetric(x: float, limit: float) -> float:
    return limit if x > limit else (-limit if x < -limit else x)


# --- the step ------------------------------------------------------------------------

@dataclass
class FingerState:
    sections: list[Biquad]
    velocity_alpha: float
    derivative_alpha: float
    chamber_alpha: float
    chamber_vent_alpha: float
    rest_mv: float
    filter_primed: bool = False
    mode: int = cfg.MODE_VENT
    last_good_mv: float = 0.0
    angle_filt_deg: float = 0.0
    velocity_deg_per_s: float = 0.0
    accel_deg_per_s2: float = 0.0
    integrator_kpa: float = 0.0
    derivative_deg_per_s: float = 0.0
    pressure_cmd_kpa: float = 0.0
    chamber_model_kpa: float = 0.0
    angle_ref_deg: float = 0.0
    velocity_ref_deg_per_s: float = 0.0
    accel_ref_deg_per_s2: float = 0.0
    jerk_ref_deg_per_s3: float = 0.0
    force_ref_n: float = 0.0
    pressure_ref_kpa: float = 0.0
    impedance_stiffness_n_per_deg: float = 0.0
    impedance_damping_n_s_per_deg: float = 0.0
    creep_ref_deg: float = 0.0
    hysteresis_ref_z: float = 0.0
    hysteresis_ref_angle_deg: float = 0.0
    hysteresis_z: float = 0.0
    hysteresis_angle_deg: float = math.nan  # none seen yet


class ReferenceHand:
    """Same interface as rtcore.Hand: fill .inputs, call step(), read .outputs."""

    def __init__(self, config: HandConfig) -> None:
        if not 1 <= config.n_fingers <= cfg.MAX_FINGERS:
            raise ConfigError(f"a hand has 1 to {cfg.MAX_FINGERS} fingers, not {config.n_fingers}")
        self.config = config
        self.dt_s = 1.0 / config.sample_rate_hz
        self.ticks = 0
        self.inputs: Inputs = allocate(Inputs, config.n_fingers)  # type: ignore[assignment]
        self.outputs: Outputs = allocate(Outputs, config.n_fingers)  # type: ignore[assignment]
        self.states = [self._new_state(c) for c in config.fingers]

    def _new_state(self, c: FingerConfig) -> FingerState:
        fill_s = valve_tau(c.prbm.effects, 1.0)
        vent_s = valve_tau(c.prbm.effects, -1.0)
        rest_mv = -c.sensor_offset_deg / c.sensor_gain_deg_per_mv
        return FingerState(
            sections=butter_sections(c.filter_order, c.filter_cutoff_hz, self.config.sample_rate_hz),
            velocity_alpha=first_order_alpha(c.velocity_cutoff_hz, self.dt_s),
            derivative_alpha=first_order_alpha(c.derivative_cutoff_hz, self.dt_s),
            chamber_alpha=math.exp(-self.dt_s / fill_s) if fill_s > 0.0 else 0.0,
            chamber_vent_alpha=math.exp(-self.dt_s / vent_s) if vent_s > 0.0 else 0.0,
            rest_mv=rest_mv,
            last_good_mv=rest_mv,
        )

    def reset(self) -> None:
        self.states = [self._new_state(c) for c in self.config.fingers]
        self.ticks = 0

    def reset_finger(self, finger: int) -> None:
        self.states[finger] = self._new_state(self.config.fingers[finger])

    def step(self) -> int:
        all_flags = 0
        for i, (c, s) in enumerate(zip(self.config.fingers, self.states, strict=True)):
            all_flags |= self._step_finger(i, c, s)
        self.ticks += 1
        return all_flags

    def _update_angle(self, c: FingerConfig, s: FingerState, mv: float) -> tuple[float, int]:
        flags = 0
        angle = c.sensor_gain_deg_per_mv * mv + c.sensor_offset_deg
        if not usable(angle):
            flags |= cfg.FLAG_SENSOR_REJECTED
            angle = c.sensor_gain_deg_per_mv * s.last_good_mv + c.sensor_offset_deg
        else:
            s.last_good_mv = mv
        if not s.filter_primed:
            x = angle
            for section in s.sections:
                section.prime(x)
                x = section.dc_gain * x
            s.angle_filt_deg, s.velocity_deg_per_s, s.accel_deg_per_s2 = x, 0.0, 0.0
            s.filter_primed = True
        filtered = angle
        for section in s.sections:
            filtered = section.run(filtered)
        a = s.velocity_alpha
        velocity = a * s.velocity_deg_per_s + (1.0 - a) * (filtered - s.angle_filt_deg) / self.dt_s
        s.accel_deg_per_s2 = (a * s.accel_deg_per_s2
                              + (1.0 - a) * (velocity - s.velocity_deg_per_s) / self.dt_s)
        s.velocity_deg_per_s = velocity
        s.angle_filt_deg = filtered
        return angle, flags

    def _hold_references(self, i: int, s: FingerState) -> dict[str, bool]:
        rejected = {}
        for name in (*REFERENCES, *IMPEDANCE_GAINS):
            value = float(getattr(self.inputs, name)[i])
            rejected[name] = not usable(value) or (name in IMPEDANCE_GAINS and value < 0.0)
            if not rejected[name]:
                setattr(s, name, value)
        return rejected

    def _step_finger(self, i: int, c: FingerConfig, s: FingerState) -> int:
        dt_s = self.dt_s
        previous_kpa, previous_mode = s.pressure_cmd_kpa, s.mode
        flags = 0
        mode = int(self.inputs.mode[i])
        if mode not in cfg.MODE_NAMES:
            mode, flags = cfg.MODE_VENT, flags | cfg.FLAG_MODE_REJECTED
        changed = mode != previous_mode
        if changed:
            flags |= cfg.FLAG_MODE_CHANGED
        s.mode = mode

        angle_deg, sensor_flags = self._update_angle(c, s, float(self.inputs.sensor_mv[i]))
        flags |= sensor_flags
        angle_rad = s.angle_filt_deg * RAD_PER_DEG

        rejected = self._hold_references(i, s)
        position_rejected = any(rejected[name] for name in POSITION_REFERENCES)
        impedance_rejected = position_rejected or any(rejected[name] for name in IMPEDANCE_GAINS)
        if ((mode == cfg.MODE_POSITION and position_rejected)
                or (mode == cfg.MODE_IMPEDANCE and impedance_rejected)
                or (mode == cfg.MODE_FORCE and rejected["force_ref_n"])
                or (mode == cfg.MODE_PRESSURE and rejected["pressure_ref_kpa"])):
            flags |= cfg.FLAG_REFERENCE_REJECTED

        alpha = s.chamber_vent_alpha if previous_kpa < s.chamber_model_kpa else s.chamber_alpha
        s.chamber_model_kpa = previous_kpa + (s.chamber_model_kpa - previous_kpa) * alpha
        chamber_kpa = float(self.inputs.pressure_meas_kpa[i])
        if not usable(chamber_kpa):
            chamber_kpa = s.chamber_model_kpa
        hysteresis_angle_update(c.prbm.effects, s)
        loop_z = s.hysteresis_z if c.force_estimate_hysteresis else 0.0
        force_n = force_normal(c, chamber_kpa, angle_rad, s.velocity_deg_per_s * RAD_PER_DEG,
                               s.accel_deg_per_s2 * RAD_PER_DEG, loop_z)
        if not math.isfinite(force_n):
            force_n, flags = 0.0, flags | cfg.FLAG_OUTPUT_REJECTED

        feedforward_kpa = pid_kpa = command_kpa = 0.0
        if mode == cfg.MODE_VENT:
            s.integrator_kpa = s.derivative_deg_per_s = 0.0
        elif mode == cfg.MODE_PRESSURE:
            command_kpa, _, limit_flags = limit_command(c, s.pressure_ref_kpa, previous_kpa, dt_s,
                                                        0.0, 0.0, 0.0)
            s.integrator_kpa = s.derivative_deg_per_s = 0.0
            feedforward_kpa = s.pressure_ref_kpa
            flags |= limit_flags
        else:
            derivative_kpa = 0.0
            if mode == cfg.MODE_POSITION:
                rate_error = s.velocity_ref_deg_per_s - s.velocity_deg_per_s
                creep_reference_update(c.prbm.effects, s, changed, dt_s)
                hysteresis_reference_update(c.prbm.effects, s, changed)
                feedforward_kpa = position_feedforward(c, s)
                error = s.angle_ref_deg - s.angle_filt_deg
                proportional_kpa = c.kp_kpa_per_deg * error
                s.derivative_deg_per_s = rate_error if changed else (
                    s.derivative_alpha * s.derivative_deg_per_s
                    + (1.0 - s.derivative_alpha) * rate_error)
                derivative_kpa = c.kd_kpa_s_per_deg * s.derivative_deg_per_s
                integral_gain = c.ki_kpa_per_deg_s
            else:
                # force, or impedance: force control on a virtual spring and damper's force
                force_ref_n = s.force_ref_n if mode == cfg.MODE_FORCE else (
                    s.impedance_stiffness_n_per_deg * (s.angle_ref_deg - s.angle_filt_deg)
                    + s.impedance_damping_n_s_per_deg * (s.velocity_ref_deg_per_s - s.velocity_deg_per_s))
                torque_rate, integral_share = 0.0, 1.0
                if mode == cfg.MODE_IMPEDANCE:
                    # the lead on the spring's part beyond 2 r K, at most IMPEDANCE_LEAD_MAX_SHARE of k
                    virtual = c.prbm.lever_arm_m * s.impedance_stiffness_n_per_deg
                    spring = model_stiffness(c.prbm, angle_rad) * RAD_PER_DEG
                    led = min(max(spring - 2.0 * virtual, 0.0), IMPEDANCE_LEAD_MAX_SHARE * spring)
                    torque_rate = led * s.velocity_deg_per_s + virtual * s.velocity_ref_deg_per_s
                    # below K_max the integral gain falls as (2 r K / k)^3 (the C step's reason)
                    if spring > 2.0 * virtual:
                        below = 2.0 * virtual / spring
                        integral_share = below * below * below
                s.derivative_deg_per_s = 0.0
                feedforward_kpa = force_feedforward(c, angle_rad, force_ref_n, loop_z, torque_rate)
                error = force_ref_n - force_n
                proportional_kpa = c.force_kp_kpa_per_n * error
                integral_gain = c.force_ki_kpa_per_n_s * integral_share
            if changed:
                # bumpless: continue the command between active modes; out of VENT, start empty
                s.integrator_kpa = 0.0 if previous_mode == cfg.MODE_VENT else clamp_symmetric(
                    previous_kpa - feedforward_kpa - proportional_kpa - derivative_kpa,
                    c.integrator_limit_kpa)
            integrator_new = s.integrator_kpa + integral_gain * error * dt_s
            pid_kpa = proportional_kpa + integrator_new + derivative_kpa
            command_kpa, s.integrator_kpa, limit_flags = limit_command(
                c, feedforward_kpa + pid_kpa, previous_kpa, dt_s, error, s.integrator_kpa,
                integrator_new)
            flags |= limit_flags

        if not all(math.isfinite(x) for x in (command_kpa, s.integrator_kpa,
                                               s.derivative_deg_per_s, feedforward_kpa, pid_kpa)):
            command_kpa = feedforward_kpa = pid_kpa = 0.0
            s.integrator_kpa = s.derivative_deg_per_s = 0.0
            flags |= cfg.FLAG_OUTPUT_REJECTED
        s.pressure_cmd_kpa = command_kpa

        out = self.outputs
        out.pressure_cmd_kpa[i] = command_kpa
        out.angle_deg[i] = angle_deg
        out.angle_filt_deg[i] = s.angle_filt_deg
        out.velocity_deg_per_s[i] = s.velocity_deg_per_s
        out.accel_deg_per_s2[i] = s.accel_deg_per_s2
        out.feedforward_kpa[i] = feedforward_kpa
        out.pid_kpa[i] = pid_kpa
        out.chamber_pressure_kpa[i] = chamber_kpa
        out.force_normal_n[i] = force_n
        out.force_est_x_n[i] = -force_n * math.sin(angle_rad)
        out.force_est_y_n[i] = force_n * math.cos(angle_rad)
        out.force_magnitude_n[i] = abs(force_n)
        out.flags[i] = flags
        return flags
