"""The project's effects (docs/formats.md §2.1, their torques in docs/physics.md §4): the
terms of the C model (csrc/rtcore_model.c; the valve's in csrc/rtcore_sim_advance.c) and
the simulated finger's loop in the angle (csrc/rtcore_sim_plant.c)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from hand_service.config.plausible import DEAD_TIME_DELAY_S, VALVE_LAG_TAU_S, VALVE_VENT_TAU_S
from hand_service.effects.base import DerivedSize, FieldEffect, FingerEffect, FitScales, Parameter

# an effect's own torque over a recording may reach this many times the largest torque the
# spring or the pressure makes in it (air drag in a fast vent can exceed them); dry friction
# only twice: beyond the driving torque the finger would never have moved
EFFECT_TORQUE_RATIO = 10.0
FRICTION_TORQUE_RATIO = 2.0


@dataclass(frozen=True)
class DryFriction(FieldEffect):
    def fit_range(self, scales: FitScales, scale: float, lower: float, upper: float) -> tuple[float, float]:
        if scales.torque_nm > 0.0:
            upper = max(upper, FRICTION_TORQUE_RATIO * scales.torque_nm)
        return lower, upper


@dataclass(frozen=True)
class Gravity(FieldEffect):
    def fit_range(self, scales: FitScales, scale: float, lower: float, upper: float) -> tuple[float, float]:
        torque = EFFECT_TORQUE_RATIO * scales.torque_nm
        if torque > 0.0 and scales.angle_rad > 0.0:
            reach = min(torque / max(1.0 - math.cos(min(scales.angle_rad, math.pi)), 1e-3),
                        1e3 * scales.torque_nm)
            upper, lower = max(upper, reach), min(lower, -reach)
        return lower, upper


@dataclass(frozen=True)
class AirDrag(FieldEffect):
    def fit_range(self, scales: FitScales, scale: float, lower: float, upper: float) -> tuple[float, float]:
        torque = EFFECT_TORQUE_RATIO * scales.torque_nm
        if torque > 0.0 and scales.speed_rad_s > 0.0:
            upper = max(upper, torque / scales.speed_rad_s**2)
        return lower, upper


@dataclass(frozen=True)
class CubicSpring(FieldEffect):
    def fit_range(self, scales: FitScales, scale: float, lower: float, upper: float) -> tuple[float, float]:
        torque = EFFECT_TORQUE_RATIO * scales.torque_nm
        if torque > 0.0 and scales.angle_rad > 0.0:
            upper = max(upper, torque / scales.angle_rad**3)
            lower = min(lower, -scales.stiffness_nm_per_rad / (3.0 * scales.angle_rad**2))
        return lower, upper


@dataclass(frozen=True)
class DeadZone(FieldEffect):
    def fit_range(self, scales: FitScales, scale: float, lower: float, upper: float) -> tuple[float, float]:
        return lower, max(upper, 0.5 * scales.command_max_kpa)


# a contact's fit starts with its onset at this quantile of the recorded angle (a stop or an
# object the finger meets only near the top of its travel, else the recording would be mostly
# in contact) and Hertz's exponent, the middle of the usual 1 to 2
CONTACT_ONSET_QUANTILE = 0.8
HERTZ_EXPONENT = 1.5


@dataclass(frozen=True)
class Contact(FieldEffect):
    def shape_start(self, name: str, angle_deg: Sequence[float]) -> float:
        if name == "onset_deg" and len(angle_deg):
            return float(np.quantile(np.asarray(angle_deg, dtype=float), CONTACT_ONSET_QUANTILE))
        if name == "exponent":
            return HERTZ_EXPONENT
        return super().shape_start(name, angle_deg)

    def derived_size(self, values: Mapping[str, float], deepest_deg: float) -> DerivedSize:
        """The spring's torque K·(θmax − θc)ⁿ at the deepest angle reached: K alone trades
        with n (its units change with it) and with the damper; this torque is what the
        recording fixes."""
        depth_rad = math.radians(max(deepest_deg - values["onset_deg"], 0.0))
        torque = values[self.param] * depth_rad ** values["exponent"] if depth_rad > 0.0 else 0.0
        return DerivedSize(float(torque), "N·m",
                           f"the spring's torque at the deepest angle reached ({deepest_deg:.1f}°)")

    @property
    def refining(self) -> tuple[str, ...]:
        # a damping that grows past an angle is what a damping growing with the pressure
        # looks like where the angle follows the pressure: the spring must carry the contact
        return ("damping_nms_per_rad",)

    def core_starts(self, values: Mapping[str, float], deepest_deg: float) -> list[dict[str, float]]:
        """Hertz's exponent, K set to keep the spring's torque at the deepest angle: without
        its damper a spring refitted from the joint's shape can slide its onset past the
        deepest angle reached (a ringing vent release, docs/results.md)."""
        depth_rad = math.radians(deepest_deg - values["onset_deg"])
        if depth_rad <= 0.0 or values["exponent"] == HERTZ_EXPONENT:
            return []
        stiffness = values[self.param] * depth_rad ** values["exponent"] / depth_rad ** HERTZ_EXPONENT
        return [{**values, self.param: stiffness, "exponent": HERTZ_EXPONENT}]


def _one(name: str, unit: str, neutral: float, lower: float, upper: float,
         scale: float) -> tuple[Parameter, ...]:
    return (Parameter(name, unit, neutral, lower, upper, scale),)


BUILTIN: tuple[FieldEffect | FingerEffect, ...] = (
    FieldEffect("valve_lag", "chamber pressure lags the command (first order)",
                _one("tau_s", "s", 0.0, VALVE_LAG_TAU_S.lower, VALVE_LAG_TAU_S.upper, 0.03),
                reference="a first-order pneumatic lag", rtcore_field="valve_lag_tau_s"),
    FieldEffect("dead_time", "transport delay between command and chamber",
                _one("delay_s", "s", 0.0, DEAD_TIME_DELAY_S.lower, DEAD_TIME_DELAY_S.upper, 0.01),
                reference="tubing transport delay", rtcore_field="dead_time_s"),
    DryFriction("coulomb_friction", "dry friction, stick-slip",
                _one("torque_nm", "N·m", 0.0, 0.0, 0.05, 0.001),
                reference="Coulomb friction, tanh-smoothed", rtcore_field="coulomb_torque_nm"),
    CubicSpring("cubic_stiffness", "stiffening: extra torque k3·θ³",
                _one("k3_nm_per_rad3", "N·m/rad³", 0.0, -2.0, 10.0, 0.05),
                reference="a hardening (Duffing) spring", rtcore_field="cubic_stiffness_nm_per_rad3"),
    Gravity("gravity", "gravity torque on the horizontal finger: −G·(1 − cos θ)",
            _one("torque_nm", "N·m", 0.0, -0.5, 0.5, 0.01),
            reference="the finger's weight about its base", rtcore_field="gravity_torque_nm"),
    FieldEffect("asymmetric_stiffness", "stiffness differs when bending backwards (θ < 0)",
                _one("stiffness_ratio", "k_neg/k_pos", 1.0, 0.05, 20.0, 0.5),
                reference="a bilinear spring", rtcore_field="asymmetric_stiffness_ratio"),
    AirDrag("quadratic_damping", "air drag: c2·|θ'|·θ'",
            _one("c2_nms2_per_rad2", "N·m·s²/rad²", 0.0, 0.0, 0.05, 1e-4),
            reference="quadratic (form) drag", rtcore_field="quadratic_damping_nms2_per_rad2"),
    DeadZone("pressure_deadzone", "no torque until the pressure passes a threshold",
             _one("threshold_kpa", "kPa", 0.0, 0.0, 100.0, 5.0),
             reference="a membrane's pre-tension", rtcore_field="pressure_deadzone_kpa"),
    # searched on request (diagnose --search): it refines a lag diagnose already has
    FieldEffect("valve_vent_lag", "the chamber vents with a lag of its own (valve_lag's then fills only)",
                _one("tau_s", "s", 0.0, VALVE_VENT_TAU_S.lower, VALVE_VENT_TAU_S.upper, 0.1),
                reference="a valve board whose exhaust is narrower than its supply",
                rtcore_field="valve_vent_tau_s", searched=False),
    Contact("contact", "a stop or object met past θc: max(Kc·(θ − θc)^n + Cc·θ', 0), one side",
                (Parameter("stiffness_nm_per_radn", "N·m/radⁿ", 0.0, 0.0, 50.0, 0.5),
                 Parameter("onset_deg", "deg", 45.0, -90.0, 180.0, 5.0),
                 Parameter("exponent", "1", 1.0, 1.0, 3.0, 0.5),
                 # a Kelvin-Voigt damper in parallel with the spring while in contact
                 Parameter("damping_nms_per_rad", "N·m·s/rad", 0.0, 0.0, 10.0, 0.01)),
                reference="penalty contact K·δⁿ (n = 1.5 is Hertz's sphere) with a Kelvin-Voigt "
                          "damper, pushing only (Hunt & Crossley 1975 scale theirs by δⁿ)",
                rtcore_field="contact_stiffness_nm_per_radn",
                more_fields=(("onset_deg", "contact_onset_deg"), ("exponent", "contact_exponent"),
                             ("damping_nms_per_rad", "contact_damping_nms_per_rad")),
                admitted_by_screen=True),
    FieldEffect("pressure_stiffening", "the chamber pressure stiffens the finger: k·(1 + c·p/p_ref)",
                (Parameter("gain", "1", 0.0, 0.0, 5.0, 0.2),
                 # c and p_ref act only as c/p_ref: p_ref sets c's units, never fitted
                 Parameter("reference_kpa", "kPa", 100.0, 1.0, 1000.0, 20.0, fitted=False)),
                reference="a fibre-reinforced actuator's pressure-dependent stiffness "
                          "(Polygerinos et al. 2015)",
                rtcore_field="pressure_stiffening_gain",
                more_fields=(("reference_kpa", "pressure_stiffening_ref_kpa"),),
                # on request: behind the screen it named a damping that grows with pressure
                # `complete` (docs/results.md §12.73); the rival check fits it
                searched=False, admitted_by_screen=True),
    FieldEffect("creep", "a standard-linear-solid branch: β·k·(θ − x), T·x' = θ − x",
                (Parameter("stiffness_ratio", "1", 0.0, 0.0, 5.0, 0.1),
                 Parameter("time_s", "s", 1.0, 0.01, 100.0, 1.0)),
                reference="Zener's standard linear solid (Zener 1948)",
                rtcore_field="creep_stiffness_ratio", more_fields=(("time_s", "creep_time_s"),),
                admitted_by_screen=True),
    FingerEffect("hysteresis", "a rate-independent loop (Dahl): −H·z, dz/dθ = (sign θ' − z)/θh",
                 (Parameter("torque_nm", "N·m", 0.0, 0.0, 0.5, 0.005),
                  Parameter("travel_deg", "deg", 5.0, 0.1, 90.0, 2.0)),
                 reference="Dahl 1968 (Bouc-Wen with its shape fixed): exact between turns",
                 fields=(("torque_nm", "hysteresis_torque_nm"), ("travel_deg", "hysteresis_travel_deg")),
                 controller_fields=(("torque_nm", "hysteresis_torque_nm"),
                                    ("travel_deg", "hysteresis_travel_deg")),
                 compensated=True, admitted_by_screen=True),
)
