"""The model file's `effects` block (docs/formats.md §2.1): parsing, values and what the
controller and the simulator take of it. The effects themselves are the library's
(hand_service/effects: the project's and the labs' entry points); the simulator, the
controller's feedforward and `diagnose` all read it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from hand_service.config.plausible import DEAD_TIME_DELAY_S, VALVE_LAG_TAU_S, VALVE_VENT_TAU_S, Plausible
from hand_service.config.schema import fail, unknown_key_message
from hand_service.config.textfile import show
from hand_service.config.yamlio import LineDict
from hand_service.effects import registry
from hand_service.effects.base import Effect, Parameter
from rtcore import Effects
from rtcore.sim import SimFinger

EffectSpec = Effect  # an effect of the library (hand_service/effects/base.py)


def __getattr__(name: str) -> object:
    """LIBRARY (every registered effect, in order), BY_NAME and SEARCHED (those `diagnose`
    searches for), read from the registry on use, so that a lab's effects (entry points)
    are in them."""
    if name == "LIBRARY":
        return registry.library()
    if name == "BY_NAME":
        return registry.by_name()
    if name == "SEARCHED":  # the effects `diagnose` searches for
        return tuple(e for e in registry.library() if e.searched)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


# the effects whose range is a physical plausibility with unit slips (config/plausible.py)
PLAUSIBLE: dict[str, Plausible] = {"valve_lag": VALVE_LAG_TAU_S, "valve_vent_lag": VALVE_VENT_TAU_S,
                                   "dead_time": DEAD_TIME_DELAY_S}

EffectParams = dict[str, dict[str, float]]


def parse_effects(data: Any, source: str | Path, context: str = "effects") -> EffectParams:
    """Validate an `effects:` block: known names, their parameters (the first one required,
    the others optional), each in range."""
    if data is None:
        return {}
    if not isinstance(data, dict):
        raise fail(source, data, None, f"{context} must map effect names to their parameters")
    known = registry.by_name()
    effects: EffectParams = {}
    for name, params in data.items():
        spec = known.get(name)
        if spec is None:
            raise fail(source, data, name, unknown_key_message(name, list(known), context))
        label = f"{context}.{name}"
        if not isinstance(params, dict):
            raise fail(source, data, name, f"{label} must be a mapping like {{{spec.param}: ...}}")
        names = [p.name for p in spec.parameters]
        for key in params:
            if key not in names:
                raise fail(source, params, key, unknown_key_message(key, names, label))
        if spec.param not in params:
            raise fail(source, data, name, f"{label} needs '{spec.param}' ({spec.unit})")
        line_owner = params if isinstance(params, LineDict) else data
        effects[name] = {key: _checked(name, spec.parameter(key), params[key], source, line_owner, label)
                         for key in names if key in params}
    return effects


def _checked(name: str, param: Parameter, value: Any, source: str | Path, line_owner: Any,
             label: str) -> float:
    number = isinstance(value, (int, float)) and not isinstance(value, bool)
    if not (number and param.lower <= value <= param.upper):
        slip = PLAUSIBLE[name].slip(value) if name in PLAUSIBLE and isinstance(value, (int, float)) \
            and not isinstance(value, bool) else None
        hint = f": {slip.unit}? ({show(value)} {slip.unit} = {value / slip.per_unit:g} s)" if slip else ""
        raise fail(source, line_owner, param.name,
                   f"{label}.{param.name} = {show(value)} is out of range "
                   f"({param.lower:g} to {param.upper:g} {param.unit}){hint}")
    return float(value)


def effect_value(effects: EffectParams, name: str) -> float:
    """The effect's primary parameter in an effects block (its neutral when absent)."""
    spec = registry.by_name()[name]
    return effects.get(name, {}).get(spec.param, spec.neutral)


def to_rtcore(effects: EffectParams) -> Effects:
    """The rtcore Effects struct (controller and simulator) for an effects block: the
    effects that are terms of the C model; the others are the simulated finger's
    (apply_to_finger)."""
    result = Effects()
    known = registry.by_name()
    for name, values in effects.items():
        for field, value in known[name].rtcore_fields(values).items():
            setattr(result, field, value)
    return result


def apply_to_finger(finger: SimFinger, effects: EffectParams) -> SimFinger:
    """`finger` with the effects that are not terms of the C model (FingerEffect, a lab's
    own) applied by their simulator hooks; the C model's are in its prbm (to_rtcore)."""
    known = registry.by_name()
    for name, values in effects.items():
        if known[name].hooked:
            finger = known[name].apply(finger, values)
    return finger


def describe(effects: EffectParams) -> str:
    return ", ".join(f"{name}(" + ", ".join(f"{k}={v:g}" for k, v in p.items()) + ")"
                     for name, p in effects.items()) or "none"
