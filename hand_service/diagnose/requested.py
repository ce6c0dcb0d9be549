"""The effects `diagnose` searches for (docs/diagnose.md, "The effect library"): the
library's searched ones and those asked for (`--search`), an effect the model file gives
with its first parameter at "none" (its shape, a contact's onset or a loop's travel, fitted
from there), and a contact searched for again where the residual's torque switches on."""

from __future__ import annotations

from collections.abc import Sequence

from hand_service.config import effects as fx
from hand_service.config.model import FingerModel
from hand_service.diagnose.report.diagnosis import Diagnosis
from hand_service.errors import UserError


def contact_at_onset(model: FingerModel, result: Diagnosis, search: list[str]) -> FingerModel | None:
    """When `contact` is searched for, not named, not in the model, and the residual shows a
    torque switching on past an angle as the finger bends (outside_library/contact_onset.py):
    the model with a contact there, its stiffness at "none" (searched for from that onset and
    power: shape_only). Else None."""
    onset = result.outside.onset
    if ("contact" not in search or "contact" in model.effects or onset is None or not onset.closing
            or (result.effects and result.effects[0].name == "contact")):
        return None
    spec = fx.BY_NAME["contact"]
    power = spec.parameter("exponent")
    contact = {spec.param: spec.neutral, "onset_deg": float(onset.angle_deg),
               "exponent": float(min(max(onset.power, power.lower), power.upper))}
    return model.with_changes(effects={**model.effects, "contact": contact})


def searched(also: Sequence[str]) -> list[str]:
    """The effects to search for: the library's searched ones, then `also` (UserError for
    an unknown name)."""
    known = fx.BY_NAME
    for name in also:
        if name not in known:
            raise UserError(f"--search {name}: unknown effect (known: {', '.join(known)})")
    names = [spec.name for spec in fx.SEARCHED]
    return names + [name for name in dict.fromkeys(also) if name not in names]


def shape_only(effects: fx.EffectParams, name: str) -> bool:
    """The model file gives the effect's other parameters with its first at "none" (a
    contact's onset where the lab's object sits, K 0): it is searched for, its shape fitted
    from them."""
    spec = fx.BY_NAME[name]
    return name in effects and len(spec.parameters) > 1 and fx.effect_value(effects, name) == spec.neutral
