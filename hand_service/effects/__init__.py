"""The effect library: physics a plain PRBM leaves out, each a small `Effect` registered by
name (builtin.py holds the project's; a lab adds its own through the `hand_service.effects`
entry point group, registry.py). The model file's `effects` block, `simulate` and
`diagnose` read the registry (hand_service/config/effects.py)."""

from hand_service.effects.base import Effect, FieldEffect, FingerEffect, Parameter
from hand_service.effects.registry import ENTRY_POINT_GROUP, by_name, library, register

__all__ = ["ENTRY_POINT_GROUP", "Effect", "FieldEffect", "FingerEffect", "Parameter", "by_name", "library",
           "register"]
