"""Each controller's setpoint, tuned once per object the way an operator does by hand.

On a centred placement of a nominal specimen, with the thumb and index finger, the
operator tries setpoints from low to high in small steps (PRESSURE_STEP_KPA on the
regulator, FORCE_STEP_N on the force target) over the instrument's range (the pair's
pressure limit; the profile's force range) and keeps the middle of the run of
setpoints, starting at the lowest one that holds, that all hold the object for 5 s. The
same rule for both controllers; the tuned value then serves every finger pair.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hand_service.config.profile import Profile
from hand_service.pinch.objects import OBJECTS, PinchObject, Placements
from hand_service.pinch.plant import HELD
from hand_service.pinch.trials import CONTROLLERS, Cell, run_cells

TUNING_PAIR = ("thumb", "index")
PRESSURE_STEP_KPA = 1.0
FORCE_STEP_N = 0.05
FORCE_RANGE_N = 10.0  # the profiles' force target range (trajectory CSV checks)


@dataclass(frozen=True)
class Tuned:
    obj: str
    controller: str
    setpoint: float  # N (force) or kPa (pressure)
    lowest_holding: float
    highest_holding: float
    unit: str


def candidates(truth: Profile, controller: str) -> np.ndarray:
    if controller == "force":
        return np.round(np.arange(FORCE_STEP_N, FORCE_RANGE_N + FORCE_STEP_N / 2, FORCE_STEP_N), 6)
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
         objects: tuple[PinchObject, ...] = OBJECTS) -> dict[tuple[str, str], Tuned]:
    """Every object's setpoint for both controllers, from one batch of nominal trials."""
    cells = []
    for obj in objects:
        for controller in CONTROLLERS:
            setpoints = candidates(truth, controller)
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
        middle = round(low + step * round((high - low) / 2.0 / step), 6)
        key = (cell.obj.name, cell.controller)
        tuned[key] = Tuned(cell.obj.name, cell.controller, middle, low, high, unit)
    return tuned
