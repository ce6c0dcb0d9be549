"""The library of physics a plain PRBM leaves out (docs/formats.md, `effects`).

Each effect is one small definition here plus its term in the C model
(csrc/rtcore_model.c: the torque; csrc/rtcore_sim_advance.c: the valve). The simulator, the
controller's feedforward and `diagnose` all read this table.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hand_service.config.plausible import DEAD_TIME_DELAY_S, VALVE_LAG_TAU_S, Plausible
from hand_service.config.schema import fail, unknown_key_message
from hand_service.config.textfile import show
from hand_service.config.yamlio import LineDict
from rtcore import Effects


@dataclass(frozen=True)
class EffectSpec:
    name: str
    param: str
    unit: str
    physics: str
    rtcore_field: str  # the rtcore_effects field the simulator and controller read
    neutral: float  # the parameter value that means "no effect"
    lower: float  # plausible range: validation and fit bounds
    upper: float
    scale: float  # a typical magnitude, for starting points and step sizes


LIBRARY: tuple[EffectSpec, ...] = (
    EffectSpec("valve_lag", "tau_s", "s", "chamber pressure lags the command (first order)",
               "valve_lag_tau_s", 0.0, VALVE_LAG_TAU_S.lower, VALVE_LAG_TAU_S.upper, 0.03),
    EffectSpec("dead_time", "delay_s", "s", "transport delay between command and chamber",
               "dead_time_s", 0.0, DEAD_TIME_DELAY_S.lower, DEAD_TIME_DELAY_S.upper, 0.01),
    EffectSpec("coulomb_friction", "torque_nm", "N·m", "dry friction, stick-slip",
               "coulomb_torque_nm", 0.0, 0.0, 0.05, 0.001),
    EffectSpec("cubic_stiffness", "k3_nm_per_rad3", "N·m/rad³", "stiffening: extra torque k3·θ³",
               "cubic_stiffness_nm_per_rad3", 0.0, -2.0, 10.0, 0.05),
    EffectSpec("gravity", "torque_nm", "N·m",
               "gravity torque on the horizontal finger: −G·(1 − cos θ)",
               "gravity_torque_nm", 0.0, -0.5, 0.5, 0.01),
    EffectSpec("asymmetric_stiffness", "stiffness_ratio", "k_neg/k_pos",
               "stiffness differs when bending backwards (θ < 0)",
               "asymmetric_stiffness_ratio", 1.0, 0.05, 20.0, 0.5),
    EffectSpec("quadratic_damping", "c2_nms2_per_rad2", "N·m·s²/rad²", "air drag: c2·|θ'|·θ'",
               "quadratic_damping_nms2_per_rad2", 0.0, 0.0, 0.05, 1e-4),
    EffectSpec("pressure_deadzone", "threshold_kpa", "kPa",
               "no torque until the pressure passes a threshold",
               "pressure_deadzone_kpa", 0.0, 0.0, 100.0, 5.0),
)
BY_NAME: dict[str, EffectSpec] = {spec.name: spec for spec in LIBRARY}
# the effects whose range is a physical plausibility with unit slips (config/plausible.py)
PLAUSIBLE: dict[str, Plausible] = {"valve_lag": VALVE_LAG_TAU_S, "dead_time": DEAD_TIME_DELAY_S}

EffectParams = dict[str, dict[str, float]]


def parse_effects(data: Any, source: str | Path, context: str = "effects") -> EffectParams:
    """Validate an `effects:` block: known names, their one parameter, in range."""
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise fail(source, data, None, f"{context} must map effect names to their parameters")
    effects: EffectParams = {}
    for name, params in data.items():
        spec = BY_NAME.get(name)
        if spec is None:
            raise fail(source, data, name, unknown_key_message(name, list(BY_NAME), context))
        label = f"{context}.{name}"
        if not isinstance(params, dict):
            raise fail(source, data, name, f"{label} must be a mapping like {{{spec.param}: ...}}")
        for key in params:
            if key != spec.param:
                raise fail(source, params, key, unknown_key_message(key, [spec.param], label))
        if spec.param not in params:
            raise fail(source, data, name, f"{label} needs '{spec.param}' ({spec.unit})")
        value = params[spec.param]
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not (
                spec.lower <= value <= spec.upper):
            line_owner = params if isinstance(params, LineDict) else data
            slip = PLAUSIBLE[name].slip(value) if name in PLAUSIBLE and isinstance(value, (int, float)) \
                and not isinstance(value, bool) else None
            hint = f": {slip.unit}? ({show(value)} {slip.unit} = {value / slip.per_unit:g} s)" if slip else ""
            raise fail(source, line_owner, spec.param,
                       f"{label}.{spec.param} = {show(value)} is out of range "
                       f"({spec.lower:g} to {spec.upper:g} {spec.unit}){hint}")
        effects[name] = {spec.param: float(value)}
    return effects


def effect_value(effects: EffectParams, name: str) -> float:
    spec = BY_NAME[name]
    return effects.get(name, {}).get(spec.param, spec.neutral)


def to_rtcore(effects: EffectParams) -> Effects:
    """The rtcore Effects struct (controller and simulator) for an effects block."""
    result = Effects()
    for name in effects:
        setattr(result, BY_NAME[name].rtcore_field, effect_value(effects, name))
    return result


def describe(effects: EffectParams) -> str:
    return ", ".join(f"{name}({BY_NAME[name].param}={p[BY_NAME[name].param]:g})"
                     for name, p in effects.items()) or "none"
