"""Where a joint fit (an effect beside k, B and N) starts, and how far its k, B and N may go."""

from __future__ import annotations

import dataclasses

import numpy as np

from hand_service.diagnose.fitting.output_error import Fit
from hand_service.diagnose.model.params import Param
from hand_service.diagnose.model.problem import Problem

ABSORBED = 0.15  # a refitted plain parameter this far from the nominal may be hiding an effect


def nominal_start(problem: Problem, base: Fit) -> np.ndarray | None:
    """`base` with k, B, N back at the model's values, when the refit moved any of them by
    more than ABSORBED: the refit may have bent them to absorb the missing effect (B
    taking up dry friction, say), and the joint fit must be able to undo that."""
    values = base.values.copy()
    nominal = problem.values(base.params)
    plain = [i for i, p in enumerate(base.params) if not p.is_effect]
    if np.all(np.abs(values[plain] - nominal[plain]) < ABSORBED * np.abs(nominal[plain])):
        return None  # (a nominal of 0, B for one, moved by any refit: no division by it)
    values[plain] = nominal[plain]
    return values


JOINT_RANGE = 30.0  # a joint fit keeps k, B and N within this factor of the refit's and the nominal's


def joint_range(problem: Problem, base: Fit) -> list[Param]:
    """`base`'s parameters, k, B and N bounded for the joint fits: from JOINT_RANGE below the
    lower of the refit's and the nominal's value to JOINT_RANGE above the higher. The plain
    refit alone may go a thousand times from the nominal (a rig far from its model is
    reported); a joint fit that wanders as far is in a basin of nonsense, and pays for it
    in simulation time (a finger 600 times too stiff takes 40 times longer to simulate)."""
    nominal = problem.values(base.params)
    out = []
    for p, value, centre in zip(base.params, base.values, nominal, strict=True):
        if not p.is_effect and value > 0.0 and centre > 0.0:
            p = dataclasses.replace(p, lower=max(p.lower, min(value, centre) / JOINT_RANGE),
                                    upper=min(p.upper, max(value, centre) * JOINT_RANGE))
        out.append(p)
    return out
