"""Each controller's setpoint, tuned the way an operator does by hand.

On a nominal specimen the operator tries setpoints from low to high in small steps
(PRESSURE_STEP_KPA on the regulator, FORCE_STEP_N on the force target) and keeps the
window of setpoints at which the object holds for 5 s, from the lowest. A setpoint holds
when every trial grasp at it holds: one centred grasp (`Rule.grasps` 1), or that many
grasps of the same specimen placed with the person's usual scatter. The search stops at
the pair's pressure limit (the regulator's) and at FORCE_SEARCH_MAX_N on the force target.
Tuned once per object on thumb and index (`Rule.per_pair` False, the setpoint then used
on every pair), or per finger pair and object, as the paper's protocol allows. Where no
setpoint holds on every grasp on a pair (per pair only), the operator keeps the best one
found (`fallback`): the window is then (NaN, NaN).

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
from hand_service.pinch.mismatch import NONE, Mismatch
from hand_service.pinch.objects import OBJECTS, PinchObject, Placements
from hand_service.pinch.plant import BROKEN, HELD, RELEASE_S
from hand_service.pinch.trials import CONTROLLERS, PAIRS, Cell, run_cells

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
    per_pair: bool = False
    grasps: int = 1

    def describe(self) -> str:
        if self.kind == "middle":
            told = f"middle of the window (force searched up to {self.force_search_max_n:g} N)"
        else:
            told = f"lowest holding x {self.margin:g}"
        if self.grasps > 1:
            told += f", holding in {self.grasps} of {self.grasps} placed grasps"
        return told + (", per finger pair" if self.per_pair else "")

    @property
    def where(self) -> str:
        grasp = "centred" if self.grasps == 1 else f"{self.grasps} grasps placed by hand"
        return f"each finger pair, {grasp}" if self.per_pair else f"thumb & index, {grasp}"

    def pick(self, low: float, high: float, step: float) -> float:
        if self.kind == "middle":
            return round(low + step * round((high - low) / 2.0 / step), 6)
        # the first step at or above the margin (1e-9: 0.15 x 1.5 / 0.05 is 4.5 plus rounding)
        return round(min(step * math.ceil(low * self.margin / step - 1e-9), high), 6)


HAND_RULE = Rule()  # once per object on thumb and index: the rule replicate --pinch uses by default
# The per-pair protocol (docs/replicate.md): the operator's written rule, and a human-like one.
OPERATOR_RULE = Rule("margin", 1.25, per_pair=True, grasps=3)
HUMAN_RULE = Rule("margin", 1.5, per_pair=True)
RULES = {"object": HAND_RULE, "operator": OPERATOR_RULE, "human": HUMAN_RULE}


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
    finger: str = "index"  # tuned with the thumb and this finger

    @property
    def unit(self) -> str:
        return "N" if self.controller == "force" else "kPa"

    @property
    def holds(self) -> bool:
        """Whether any setpoint held on the tuning grasps (else the setpoint is the fallback's)."""
        low = self.in_own_unit()[0]
        return low == low

    def in_own_unit(self) -> tuple[float, float, float]:
        """(lowest holding, highest holding, setpoint) in this controller's unit."""
        got = ((self.lowest_holding_n, self.highest_holding_n, self.setpoint_n) if self.controller == "force"
               else (self.lowest_holding_kpa, self.highest_holding_kpa, self.setpoint_kpa))
        assert all(v is not None for v in got)
        return got  # type: ignore[return-value]


def candidates(truth: Profile, controller: str, force_search_max_n: float = FORCE_SEARCH_MAX_N,
               pair: tuple[str, str] = TUNING_PAIR) -> np.ndarray:
    if controller == "force":
        return np.round(np.arange(FORCE_STEP_N, force_search_max_n + FORCE_STEP_N / 2, FORCE_STEP_N), 6)
    limit = min(f.pressure_max_kpa for f in truth.fingers if f.name in pair)
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


def fallback(setpoints: np.ndarray, held_grasps: np.ndarray, broke: np.ndarray) -> float:
    """Where no setpoint holds on every grasp: the one that held the most grasps (the
    lowest of those), else the highest below the first that broke the object (the firmest
    grip that does not break it), else the highest tried."""
    if held_grasps.max(initial=0) > 0:
        return float(setpoints[int(np.argmax(held_grasps))])
    breaking = np.flatnonzero(broke)
    if breaking.size == 0:
        return float(setpoints[-1])
    return float(setpoints[max(breaking[0] - 1, 0)])


def tune(truth: Profile, controller_profile: Profile, seed: int,
         objects: tuple[PinchObject, ...] = OBJECTS, rule: Rule = HAND_RULE,
         pairs: tuple[tuple[str, str], ...] = PAIRS,
         mismatch: Mismatch = NONE, release_s: float = RELEASE_S) -> dict[tuple[str, str, str], Tuned]:
    """Every (finger, object, controller)'s setpoint, from one batch of tuning grasps; tuned
    on thumb and index and shared by every pair unless the rule is per pair."""
    place_seed, run_seed = (int(s) for s in np.random.SeedSequence([seed, 42]).generate_state(2))
    rng = np.random.default_rng(place_seed)
    tuned_pairs = pairs if rule.per_pair else (TUNING_PAIR,)
    cells = []
    for pair in tuned_pairs:
        for obj in objects:
            grasps = (Placements.nominal(obj, 1) if rule.grasps == 1
                      else Placements.regrasped(obj, rule.grasps, rng))
            for controller in CONTROLLERS:
                setpoints = candidates(truth, controller, rule.force_search_max_n, pair)
                cells.append(Cell(pair, obj, controller, np.repeat(setpoints, rule.grasps),
                                  grasps.tiled(len(setpoints))))
    result = run_cells(truth, controller_profile, cells, run_seed, mismatch=mismatch, release_s=release_s)
    tuned: dict[tuple[str, str, str], Tuned] = {}
    for k, cell in enumerate(cells):
        outcome = result.outcome[result.cell_of_trial == k].reshape(-1, rule.grasps)
        held = (outcome == HELD).all(axis=1)
        setpoints = cell.setpoints[::rule.grasps]
        found = window(setpoints, held)
        unit = "N" if cell.controller == "force" else "kPa"
        step = FORCE_STEP_N if cell.controller == "force" else PRESSURE_STEP_KPA
        if found is not None:
            low, high = found
            chosen = rule.pick(low, high, step)
        elif rule.per_pair:
            chosen = fallback(setpoints, (outcome == HELD).sum(axis=1), (outcome == BROKEN).any(axis=1))
            low = high = float("nan")
        else:
            from hand_service.errors import UserError

            raise UserError(f"pinch tuning: no {cell.controller} setpoint up to {setpoints[-1]:g} {unit} "
                            f"holds the {cell.obj.name} on thumb & {cell.pair[1]} ({rule.where})")
        if cell.controller == "force":
            got = Tuned(cell.obj.name, cell.controller, setpoint_n=chosen, lowest_holding_n=low,
                        highest_holding_n=high, finger=cell.pair[1])
        else:
            got = Tuned(cell.obj.name, cell.controller, setpoint_kpa=chosen, lowest_holding_kpa=low,
                        highest_holding_kpa=high, finger=cell.pair[1])
        for pair in (pairs if not rule.per_pair else (cell.pair,)):
            tuned[(pair[1], cell.obj.name, cell.controller)] = got
    return tuned
