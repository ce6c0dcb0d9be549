"""One quick trial per object through the daemon's C step, both controllers: held at a
setpoint inside the object's window, lost for the physical reason outside it."""

from __future__ import annotations

import numpy as np

from hand_service.config.profile import Profile
from hand_service.pinch.objects import CHIP, COIN, SCREWDRIVER, PinchObject, Placements
from hand_service.pinch.plant import BROKEN, HELD, SLIPPED
from hand_service.pinch.trials import Cell, run_cells

INDEX = ("thumb", "index")


def one(obj: PinchObject, controller: str, setpoint: float, placement: Placements | None = None) -> Cell:
    return Cell(INDEX, obj, controller, np.array([setpoint]), placement or Placements.nominal(obj, 1))


def test_one_trial_per_object_is_held_by_both_controllers(truth: Profile) -> None:
    cells = [one(CHIP, "force", 0.5), one(SCREWDRIVER, "force", 4.0), one(COIN, "force", 2.0),
             one(CHIP, "pressure", 69.0), one(SCREWDRIVER, "pressure", 100.0), one(COIN, "pressure", 80.0)]
    result = run_cells(truth, truth, cells, seed=3, record=(0,))
    assert list(result.outcome) == [HELD] * len(cells)
    # force control holds the true force at its target (the Moore-Penrose estimate is unbiased)
    assert abs(result.held_force_n[1] - 4.0) < 0.2 and abs(result.held_force_n[2] - 2.0) < 0.2
    trace = result.traces[0]
    assert trace.t_s.size == 700 and np.max(trace.slip_m) == 0.0


def test_each_object_fails_for_its_own_reason(truth: Profile) -> None:
    lateral = Placements.nominal(COIN, 1)
    lateral.lateral_m[:] = 0.004  # well off the median plane: the rim meets the pad's flank
    cells = [one(CHIP, "force", 3.0),  # far above the chip's strength
             one(SCREWDRIVER, "force", 0.5),  # too little grip for the handle's torque
             one(COIN, "force", 2.0, lateral)]
    result = run_cells(truth, truth, cells, seed=3)
    assert list(result.outcome) == [BROKEN, SLIPPED, SLIPPED]
