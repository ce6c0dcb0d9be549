"""The simulated hand built from profiles and models (the C simulator is rtcore.sim).

The truth of a simulated finger is its model (k, B, N, A, lever arm and every effect in
its `effects` block) plus the profile's `simulation:` section (noise, ADC, seed).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from hand_service.config import effects as fx
from hand_service.config.model import FingerModel
from hand_service.config.pneumatics import valves_for
from hand_service.config.profile import FingerProfile, Profile
from hand_service.errors import UserError
from rtcore.pneumatic import PneumaticValves
from rtcore.sim import SimFinger, Simulator, simulate

SUPPLY_MAX_KPA = 300.0  # what the rig's regulators can deliver


@dataclass
class Contact:
    """An object the finger meets past angle_deg: a spring-damper at the force point."""

    angle_deg: float
    stiffness_n_per_m: float = 2000.0
    damping_ns_per_m: float = 5.0


def sim_finger(model: FingerModel, sensor_gain_deg_per_mv: float = 1.0, sensor_offset_deg: float = 0.0,
               sensor_noise_deg: float = 0.0, adc_step_mv: float = 0.0, pressure_noise_kpa: float = 0.0,
               contact: Contact | None = None,
               extra_effects: fx.EffectParams | None = None,
               pneumatic: PneumaticValves | None = None) -> SimFinger:
    """A simulated finger whose truth is `model` (plus `extra_effects`, hidden from the model).
    The model's lever arm is needed only where the finger meets an object (`contact`)."""
    finger = SimFinger(
        prbm=model.prbm("simulation" if contact is None else "simulating a contact", extra_effects,
                        force_point=contact is not None),
        supply_min_kpa=0.0,
        supply_max_kpa=SUPPLY_MAX_KPA,
        contact_angle_deg=contact.angle_deg if contact else 0.0,
        contact_stiffness_n_per_m=contact.stiffness_n_per_m if contact else 0.0,
        contact_damping_ns_per_m=contact.damping_ns_per_m if contact else 0.0,
        sensor_gain_deg_per_mv=sensor_gain_deg_per_mv,
        sensor_offset_deg=sensor_offset_deg,
        sensor_noise_deg=sensor_noise_deg,
        adc_step_mv=adc_step_mv,
        pressure_noise_kpa=pressure_noise_kpa,
        pneumatic=pneumatic or PneumaticValves(),
    )
    # the effects that are not terms of the C model, by their own simulator hooks
    return fx.apply_to_finger(finger, {**model.effects, **(extra_effects or {})})


def profile_sim_finger(finger: FingerProfile, simulation: dict, contact: Contact | None = None) -> SimFinger:
    return sim_finger(finger.model, finger.sensor_gain_deg_per_mv, finger.sensor_offset_deg,
                      simulation["sensor_noise_deg"], simulation["adc_step_mv"],
                      simulation["pressure_noise_kpa"], contact, pneumatic=valves_for(simulation))


RINGING_LIMIT = 1000.0  # a finger's ringing frequency, at most this many times the sample rate


def check_ringing(model: FingerModel, finger: SimFinger, rate_hz: float, rate_is: str) -> None:
    """A finger that rings over a thousand times faster than it is sampled (`rate_is`: whose
    rate that is) is a model in the wrong units, said in one line: nothing sampled so could
    show it, and its simulation would crawl at its time scale (k = 1e9 N·m/rad for a finger
    of A = 1.6e-4 kg·m² ran for minutes, 1e300 for ever). An over-damped finger, however
    stiff, moves on its slow time scale and passes."""
    prbm = finger.prbm
    a, b, k = prbm.inertia_kgm2, prbm.damping_nms_per_rad, prbm.stiffness_nm_per_rad
    zeta = b / (2.0 * math.sqrt(k * a))
    ringing_hz = math.sqrt(k / a) * math.sqrt(max(0.0, 1.0 - zeta * zeta)) / (2.0 * math.pi)
    if zeta < 1.0 and ringing_hz > RINGING_LIMIT * rate_hz:
        raise UserError(f"{model.source}: {model.finger or 'the model'}: the finger rings at "
                        f"{ringing_hz:.3g} Hz, {ringing_hz / rate_hz:.3g} times {rate_is} {rate_hz:.3g} Hz: "
                        "nothing sampled so could show that; are k (N·m/rad) and A (kg·m²) in their units?")


def hand_simulator(profile: Profile, seed: int | None = None,
                   contacts: dict[str, Contact] | None = None) -> Simulator:
    """The profile's hand as a simulator at the profile's control rate."""
    contacts = contacts or {}
    sim = profile.simulation
    fingers = [profile_sim_finger(f, sim, contacts.get(f.name)) for f in profile.fingers]
    for finger, sim_f in zip(profile.fingers, fingers, strict=True):
        check_ringing(finger.model, sim_f, profile.control.rate_hz, "the control rate,")
    return Simulator(fingers, sample_rate_hz=profile.control.rate_hz, substeps=sim["substeps"],
                     seed=sim["seed"] if seed is None else seed)


__all__ = ["Contact", "SimFinger", "Simulator", "check_ringing", "hand_simulator", "profile_sim_finger",
           "sim_finger", "simulate"]
