"""The parameters `diagnose` fits: a `Param` names one (a plain PRBM field, or a library
effect's size or one of its shape parameters) with its scale and bounds, and `EffectScales`
says what sets an effect's plausible size in one recording."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hand_service.config import effects as fx

# the library's torque ranges (config/effects.py) were set for the paper's fingers, k from
# 0.51 to 0.65 N·m/rad, with room to spare: they hold as they are up to 1 N·m/rad
REFERENCE_STIFFNESS_NM_PER_RAD = 1.0
PLAIN_RANGE = 1000.0  # k, B and N may go this many times above or below the nominal


@dataclass(frozen=True)
class Param:
    """One free parameter: a PRBM field, or a library effect's parameter (its first, or one
    of its shape: `member`)."""

    label: str  # plain field name, or the effect's name
    field: str  # rtcore Prbm field, or rtcore Effects field
    is_effect: bool
    scale: float  # typical magnitude: the optimiser works in value/scale
    lower: float
    upper: float
    unit: str = ""
    member: str = ""  # an effect's parameter beyond the first (Effect.shape_parameters); "" the first

    @property
    def is_size(self) -> bool:
        """An effect's first parameter: its size (neutral is "no effect")."""
        return self.is_effect and not self.member

    @staticmethod
    def shape(name: str, member: str) -> Param:
        """The effect's shape parameter `member` (an onset, a travel, a time), its range the
        library's."""
        p = fx.BY_NAME[name].parameter(member)
        return Param(name, member, True, p.scale, p.lower, p.upper, p.unit, member)

    @staticmethod
    def plain(name: str, nominal: float) -> Param:
        unit = {"stiffness_nm_per_rad": "N·m/rad", "damping_nms_per_rad": "N·m·s/rad",
                "pressure_gain_nm_per_kpa": "N·m/kPa"}[name]
        scale = abs(nominal) if nominal > 0 else 1e-3
        # wide, so that a rig far from its nominal is reported as found, not clipped: a
        # thousandth to a thousand times the nominal (the nominal's own uncertainty, when
        # the recording cannot pin a parameter, is the prior's business, not a bound's)
        return Param(name, name, False, scale, scale / PLAIN_RANGE, scale * PLAIN_RANGE, unit)

    @staticmethod
    def effect(name: str, scales: EffectScales | None = None) -> Param:
        """The library effect's parameter, its range scaled to this finger and recording
        (the library's ranges were set for the paper's fingers): a torque-like effect's
        scale and bounds grow with the finger's stiffness past those fingers, and its bounds
        reach as far as the recording's own torques allow (`torque_nm`, the largest torque
        the spring or the pressure makes: dry friction up to twice it, gravity, air drag at
        the finger's top speed and a cubic spring at the largest angle up to ten times it,
        a softening cubic down to where the spring would stop resisting); the dead zone may
        reach half the largest command recorded. A rig of another scale is fitted, not
        clipped: the bounds keep the numbers sane, they are no prior (an estimate pinned at
        one is not named)."""
        spec = fx.BY_NAME[name]
        sc = scales or EffectScales()
        scale, lower, upper = spec.scale, spec.lower, spec.upper
        if spec.unit.startswith("N·m"):
            factor = max(1.0, sc.stiffness_nm_per_rad / REFERENCE_STIFFNESS_NM_PER_RAD)
            scale, lower, upper = scale * factor, lower * factor, upper * factor
        lower, upper = spec.fit_range(sc, scale, lower, upper)  # the effect's own reach
        return Param(name, getattr(spec, "rtcore_field", name), True, scale, lower, upper, spec.unit)


@dataclass(frozen=True)
class EffectScales:
    """What sets an effect's plausible size in one recording (Param.effect)."""

    stiffness_nm_per_rad: float = REFERENCE_STIFFNESS_NM_PER_RAD
    command_max_kpa: float = 0.0
    torque_nm: float = 0.0  # the largest torque the spring or the pressure makes in it
    speed_rad_s: float = 0.0  # the finger's top speed (99th percentile)
    angle_rad: float = 0.0  # the largest angle reached

    @staticmethod
    def of(stiffness_nm_per_rad: float, gain_nm_per_kpa: float, pressure_kpa: np.ndarray,
           angle_deg: np.ndarray, rate_hz: float) -> EffectScales:
        """From the model's k and N and a simulated angle on the recorded command."""
        angle_rad = float(np.max(np.abs(angle_deg))) * np.pi / 180.0
        command_max_kpa = float(np.max(np.abs(pressure_kpa)))
        speed = np.abs(np.gradient(angle_deg)) * rate_hz * np.pi / 180.0
        torque = max(stiffness_nm_per_rad * angle_rad, gain_nm_per_kpa * command_max_kpa)
        return EffectScales(stiffness_nm_per_rad, command_max_kpa, float(torque),
                            float(np.percentile(speed, 99)) if speed.size else 0.0, angle_rad)
