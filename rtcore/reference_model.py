"""The PRBM's torque model with its effects, line by line the C of csrc/rtcore_model.c: the
part of the readable reference (rtcore/reference.py) that the controller's feedforward, its
force estimate and `calibrate gain` share."""

from __future__ import annotations

import math
from typing import Protocol

from rtcore.config import Effects, Prbm

RAD_PER_DEG = math.pi / 180.0


def valve_tau(e: Effects, rising: float) -> float:
    """The valve's lag toward a pressure that rises (rising > 0: fill) or falls (vent)."""
    return e.valve_lag_tau_s if rising > 0.0 or not e.valve_vent_tau_s > 0.0 else e.valve_vent_tau_s


def linear_stiffness(m: Prbm, angle_rad: float) -> float:
    if angle_rad < 0.0:
        return m.stiffness_nm_per_rad * m.effects.asymmetric_stiffness_ratio
    return m.stiffness_nm_per_rad


def model_torque(m: Prbm, angle_rad: float, velocity: float) -> float:
    """k th + k3 th^3 + c2 |th'| th' + Tc tanh(th'/w) + G (1 - cos th)
    + max(Kc (th - th_c)^n + Cc th', 0) past th_c."""
    e = m.effects
    torque = linear_stiffness(m, angle_rad) * angle_rad
    torque += e.cubic_stiffness_nm_per_rad3 * angle_rad * angle_rad * angle_rad
    torque += e.quadratic_damping_nms2_per_rad2 * abs(velocity) * velocity
    if e.coulomb_torque_nm != 0.0:
        smoothing = e.coulomb_smoothing_deg_per_s * RAD_PER_DEG
        torque += e.coulomb_torque_nm * math.tanh(velocity / smoothing)
    if e.gravity_torque_nm != 0.0:
        torque += e.gravity_torque_nm * (1.0 - math.cos(angle_rad))
    if e.contact_stiffness_nm_per_radn > 0.0:
        torque += contact_torque(e, angle_rad, velocity) if contact_depth(e, angle_rad) > 0.0 else 0.0
    return torque


def contact_depth(e: Effects, angle_rad: float) -> float:
    depth = angle_rad - e.contact_onset_deg * RAD_PER_DEG
    return depth if e.contact_stiffness_nm_per_radn > 0.0 and depth > 0.0 else 0.0


def contact_push(e: Effects, angle_rad: float, velocity: float) -> float:
    """Kc max(th - th_c, 0)^n + Cc th': in contact, continued across the onset."""
    depth = contact_depth(e, angle_rad)
    spring = e.contact_stiffness_nm_per_radn * math.pow(depth, e.contact_exponent) if depth > 0.0 else 0.0
    return spring + e.contact_damping_nms_per_rad * velocity


def contact_torque(e: Effects, angle_rad: float, velocity: float = 0.0) -> float:
    """The push in contact, pushing only (0 at rest before the onset)."""
    return max(contact_push(e, angle_rad, velocity), 0.0)


def contact_stiffness(e: Effects, angle_rad: float) -> float:
    depth = contact_depth(e, angle_rad)
    return e.contact_exponent * e.contact_stiffness_nm_per_radn * math.pow(depth, e.contact_exponent - 1.0) \
        if depth > 0.0 else 0.0


def model_stiffness(m: Prbm, angle_rad: float) -> float:
    e = m.effects
    stiffness = linear_stiffness(m, angle_rad) + 3.0 * e.cubic_stiffness_nm_per_rad3 * angle_rad * angle_rad
    if e.gravity_torque_nm != 0.0:
        stiffness += e.gravity_torque_nm * math.sin(angle_rad)
    if e.contact_stiffness_nm_per_radn > 0.0:
        stiffness += contact_stiffness(e, angle_rad)
    return stiffness


def model_torque_rate(m: Prbm, angle_rad: float, velocity: float, accel: float) -> float:
    e = m.effects
    d_velocity = 2.0 * e.quadratic_damping_nms2_per_rad2 * abs(velocity)
    if e.coulomb_torque_nm != 0.0:
        smoothing = e.coulomb_smoothing_deg_per_s * RAD_PER_DEG
        th = math.tanh(velocity / smoothing)
        d_velocity += e.coulomb_torque_nm * (1.0 - th * th) / smoothing
    rate = model_stiffness(m, angle_rad) * velocity
    if contact_depth(e, angle_rad) > 0.0:
        if contact_push(e, angle_rad, velocity) > 0.0:
            d_velocity += e.contact_damping_nms_per_rad
        else:
            rate -= contact_stiffness(e, angle_rad) * velocity
    return rate + d_velocity * accel


def deadzone_invert(e: Effects, pressure_kpa: float) -> float:
    if e.pressure_deadzone_kpa > 0.0 and pressure_kpa > 0.0:
        return pressure_kpa + e.pressure_deadzone_kpa
    return pressure_kpa


def effective_pressure(e: Effects, pressure_kpa: float) -> float:
    p0 = e.pressure_deadzone_kpa
    if p0 > 0.0:
        return pressure_kpa - p0 if pressure_kpa > p0 else 0.0
    return pressure_kpa


STIFFENED_GAIN_FLOOR = 0.1  # the share of N a stiffened finger keeps at least


def stiffening_torque(m: Prbm, angle_rad: float, effective_kpa: float) -> float:
    """k c (p_eff / p_ref) th: the pressure's stiffening."""
    e = m.effects
    if not e.pressure_stiffening_gain > 0.0:
        return 0.0
    per_kpa = effective_kpa / e.pressure_stiffening_ref_kpa
    return m.stiffness_nm_per_rad * e.pressure_stiffening_gain * per_kpa * angle_rad


def stiffened_gain_share(m: Prbm, angle_rad: float) -> float:
    """1 - k c th / (N p_ref), at least the floor."""
    if not m.effects.pressure_stiffening_gain > 0.0 or not m.pressure_gain_nm_per_kpa > 0.0:
        return 1.0
    return max(1.0 - stiffening_torque(m, angle_rad, 1.0) / m.pressure_gain_nm_per_kpa, STIFFENED_GAIN_FLOOR)


# --- the feedforward's own copies of the effects' states (csrc/rtcore_model.c) ----------

class FingerState(Protocol):
    """What of a finger's state (rtcore/reference.py FingerState) the copies read and keep."""

    angle_filt_deg: float
    angle_ref_deg: float
    velocity_ref_deg_per_s: float
    creep_ref_deg: float
    hysteresis_ref_z: float
    hysteresis_ref_angle_deg: float
    hysteresis_z: float
    hysteresis_angle_deg: float


def creep_reference_update(e: Effects, s: FingerState, entered: bool, dt_s: float) -> None:
    """The creep branch's dashpot driven by the angle reference over the tick."""
    if not e.creep_stiffness_ratio > 0.0:
        return
    if entered:
        s.creep_ref_deg = s.angle_filt_deg
    s.creep_ref_deg = s.angle_ref_deg + (s.creep_ref_deg - s.angle_ref_deg) * math.exp(-dt_s / e.creep_time_s)


def hysteresis_reference_update(e: Effects, s: FingerState, entered: bool) -> None:
    """The hysteresis loop's z driven by the angle reference led by the valve lag (the
    fill's while it bends, the vent's while it opens) + dead time (Dahl's, exact over that
    angle's travel since the last tick); at its middle from the filtered angle on entering
    position mode or when its state is not finite."""
    lead_s = valve_tau(e, s.velocity_ref_deg_per_s) + e.dead_time_s
    led_deg = s.angle_ref_deg + lead_s * s.velocity_ref_deg_per_s
    if not e.hysteresis_torque_nm > 0.0:
        return
    if entered or not (math.isfinite(s.hysteresis_ref_z) and math.isfinite(s.hysteresis_ref_angle_deg)):
        s.hysteresis_ref_z = 0.0
        s.hysteresis_ref_angle_deg = s.angle_filt_deg
    travel_deg = led_deg - s.hysteresis_ref_angle_deg
    if travel_deg != 0.0 and math.isfinite(travel_deg):
        toward = 1.0 if travel_deg > 0.0 else -1.0
        decay = math.exp(-abs(travel_deg) / e.hysteresis_travel_deg)
        s.hysteresis_ref_z = toward + (s.hysteresis_ref_z - toward) * decay
        s.hysteresis_ref_angle_deg = led_deg


def hysteresis_angle_update(e: Effects, s: FingerState) -> None:
    """The hysteresis loop's z driven by the filtered angle, every tick (the force estimate's
    and the force feedforward's); at its middle from the first angle or a non-finite state."""
    if not e.hysteresis_torque_nm > 0.0:
        return
    if not (math.isfinite(s.hysteresis_z) and math.isfinite(s.hysteresis_angle_deg)):
        s.hysteresis_z = 0.0
        s.hysteresis_angle_deg = s.angle_filt_deg
    travel_deg = s.angle_filt_deg - s.hysteresis_angle_deg
    if travel_deg != 0.0 and math.isfinite(travel_deg):
        toward = 1.0 if travel_deg > 0.0 else -1.0
        decay = math.exp(-abs(travel_deg) / e.hysteresis_travel_deg)
        s.hysteresis_z = toward + (s.hysteresis_z - toward) * decay
        s.hysteresis_angle_deg = s.angle_filt_deg


def hysteresis_torque(e: Effects, hysteresis_z: float) -> float:
    """The loop's torque H z (0 without the effect)."""
    return e.hysteresis_torque_nm * hysteresis_z if e.hysteresis_torque_nm > 0.0 else 0.0
