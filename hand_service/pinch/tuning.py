"""Each controller's setpoint, tuned once per object the way an operator does by hand.

On a centred placement of a nominal specimen, with the thumb and index finger, the
operator tries setpoints from low to high in small steps (PRESSURE_STEP_KPA on the
regulator, FORCE_STEP_N on the force target) until the object holds for 5 s, and keeps
going while it holds: the window of holding setpoints, from the lowest. The search stops
at the pair's pressure limit (the regulator's) and at FORCE_SEARCH_MAX_N on the force
target.

The rule (`Rule`): the lowest setpoint that holds times a safety margin (the same margin
for both controllers), no higher than the top of the window (above it the object broke
or slipped on the tuning trial itself; for pressure the regulator's limit). The window's
top depends on the search caps only where the margin reaches it. The paper's operator
"tuned manually to a specific value"; `Rule("middle")`, the middle of the window, is kept
for the sensitivity study (hand_service.pinch.sensitivity): it depends on the caps.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from hand_service.config.profile import Profile
from hand_service.pinch.objects import OBJECTS, PinchObject, Placements
from hand_service.pinch.plant import HELD
from hand_service.pinch.trials import CONTROLLERS, Cell, run_cells

TUNING_PAIR = ("thumb", "index")
PRESSURE_STEP_KPA = 1.0
FORCE_STEP_N = 0.05
FORCE_SEARCH_MAX_N = 10.0  # the profiles' force target range (trajectory CSV checks)
DEFAULT_MARGIN = 1.5


@dataclass(frozen=True)
class Rule:
    """How the operator picks the setpoint in the window: "margin" (the lowest holding setpoint
    times `margin`, capped at the window's top) or "middle" (the window's middle)."""

    kind: str = "margin"
    margin: float = DEFAULT_MARGIN
    force_search_max_n: float = FORCE_SEARCH_MAX_N

    def describe(self) -> str:
        if self.kind == "middle":
            return f"middle of the window (force searched up to {self.force_search_max_n:g} N)"
        return f"lowest holding x {self.margin:g}"

    def pick(self, low: float, high: float, step: float) -> float:
        if self.kind == "middle":
            return round(low + step * round((high - low) / 2.0 / step), 6)
        # the first step at or above the margin (1e-9: 0.15 x 1.5 / 0.05 is 4.5 plus rounding)
        return round(min(step * math.ceil(low * self.margin / step - 1e-9), high), 6)


HAND_RULE = Rule()  # the rule replicate --pinch uses


@dataclass(frozen=True)
class Tuned:
    """One object's tuning for one controller: force control's values in N, constant
    pressure's in kPa (the other unit's fields are None)."""

    obj: str
    controller: str
    setpoint_n: float | None = None
    lowest_holding_n: float | None = None
    highest_holding_n: float | None = None
    setpoint_kpa: float | None = None
    lowest_holding_kpa: float | None = None
    highest_holding_kpa: float | None = None

    @property
    def unit(self) -> str:
        return "N" if self.controller == "force" else "kPa"

    def in_own_unit(self) -> tuple[float, float, float]:
        """(lowest holding, highest holding, setpoint) in this controller's unit."""
        got = ((self.lowest_holding_n, self.highest_holding_n, self.setpoint_n) if self.controller == "force"
               else (self.lowest_holding_kpa, self.highest_holding_kpa, self.setpoint_kpa))
        assert all(v is not None for v in got)
        return got  # type: ignore[return-value]


def candidates(truth: Profile, controller: str, force_search_max_n: float = FORCE_SEARCH_MAX_N) -> np.ndarray:
    if controller == "force":
        return np.round(np.arange(FORCE_STEP_N, force_search_max_n + FORCE_STEP_N / 2, FORCE_STEP_N), 6)
    limit = min(f.pressure_max_kpa for f in truth.fingers if f.name in TUNING_PAIR)
    return np.arange(PRESSURE_STEP_KPA, limit + PRESSURE_STEP_KPA / 2, PRESSURE_STEP_KPA)


def window(setpoints: np.ndarray, held: np.ndarray) -> tuple[float, float] | None:
    """The run of holding setpoints that starts at the lowest one that holds."""
    holding = np.flatnonzero(held)
    if holding.size == 0:
        return None
    first = holding[0]
    last = first
    while last + 1 < len(held) and held[last + 1]:
        last += 1
    return float(setpoints[first]), float(setpoints[last])


def tune(truth: Profile, controller_profile: Profile, seed: int,
         objects: tuple[PinchObject, ...] = OBJECTS, rule: Rule = HAND_RULE) -> dict[tuple[str, str], Tuned]:
    """Every object's setpoint for both controllers, from one batch of nominal trials."""
    cells = []
    for obj in objects:
        for controller in CONTROLLERS:
            setpoints = candidates(truth, controller, rule.force_search_max_n)
            nominal = Placements.nominal(obj, len(setpoints))
            cells.append(Cell(TUNING_PAIR, obj, controller, setpoints, nominal))
    result = run_cells(truth, controller_profile, cells, seed)
    tuned = {}
    for k, cell in enumerate(cells):
        held = result.outcome[result.cell_of_trial == k] == HELD
        found = window(cell.setpoints, held)
        unit = "N" if cell.controller == "force" else "kPa"
        if found is None:
            from hand_service.errors import UserError

            raise UserError(f"pinch tuning: no {cell.controller} setpoint up to "
                            f"{cell.setpoints[-1]:g} {unit} "
                            f"holds the {cell.obj.name} on a centred placement")
        low, high = found
        step = FORCE_STEP_N if cell.controller == "force" else PRESSURE_STEP_KPA
        chosen = rule.pick(low, high, step)
        key = (cell.obj.name, cell.controller)
        if cell.controller == "force":
            tuned[key] = Tuned(cell.obj.name, cell.controller, setpoint_n=chosen, lowest_holding_n=low,
                               highest_holding_n=high)
        else:
            tuned[key] = Tuned(cell.obj.name, cell.controller, setpoint_kpa=chosen, lowest_holding_kpa=low,
                               highest_holding_kpa=high)
    return tuned
