"""A rival to a named effect, fitted in full: the final model with that effect taken out and
the rival's own physics put in (the simulator's: an object past an angle, a loop in the
angle), its other found effects held as fitted, k, B, N and the rival's parameters refitted
by output error. contact_onset.py and material_hysteresis.py compare such a rival with the
named model on the innovations."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from hand_service.diagnose.fitting.output_error import (
    Fit,
    PriorRows,
    cost_tolerance,
    error_rows,
    nominal_prior,
    parallel_columns,
)
from hand_service.diagnose.model.problem import Problem
from rtcore.sim import SimFinger

PLAIN_BOUNDS = (0.05, 20.0)  # k, B and N, as factors of their fitted values


Build = Callable[[SimFinger, np.ndarray], SimFinger]
Sensed = Callable[[np.ndarray, np.ndarray], np.ndarray]  # (simulated angle, extra) -> what the sensor reads


@dataclass(frozen=True)
class Rival:
    rss: float  # the innovations' RSS on the fitting samples
    extra: np.ndarray  # the rival's own parameters, fitted
    angle_deg: np.ndarray  # its simulated angle, from the recorded command


def fit_rival(problem: Problem, final: Fit, replaced: list[str], extra0: np.ndarray, lower: np.ndarray,
              upper: np.ndarray, build: Build) -> tuple[float, np.ndarray]:
    """rival_model's RSS and fitted `extra`."""
    rival = rival_model(problem, final, replaced, extra0, lower, upper, build)
    return rival.rss, rival.extra


def rival_model(problem: Problem, final: Fit, replaced: list[str], extra0: np.ndarray, lower: np.ndarray,
                upper: np.ndarray, build: Build, sensed: Sensed | None = None) -> Rival:
    """`final` with the effects `replaced` at neutral, and `build(finger, extra)` adding the
    rival's physics for its parameters `extra` (from extra0, within lower and upper), or
    `sensed(angle, extra)` putting it between the simulated angle and the sensor. k, B
    and N are held by the same prior as `final` was (the engine's, or the nominal's where
    the effect's fit needed it), so a comparison's gain is the data's alone. Returns the
    innovations' RSS on the fitting samples, the fitted `extra` and the rival's angle."""
    plain = [p for p in final.params if not p.is_effect]
    without = final.without(problem, replaced)
    start = problem.values(plain, final.finger)
    prior = problem.prior if problem.prior.widths or final.prior_information is None else \
        nominal_prior(problem, plain, final.sigma_deg)
    prior_rows = PriorRows.of(prior, plain)
    n_plain = len(plain)

    def finger(x: np.ndarray) -> SimFinger:
        return build(problem.finger(plain, x[:n_plain] * start, without), x[n_plain:])

    def angle_of(x: np.ndarray) -> np.ndarray:
        angle = problem.simulate(finger(x))
        return angle if sensed is None else sensed(angle, x[n_plain:])

    def rows(x: np.ndarray) -> np.ndarray:
        error = error_rows(problem, angle_of(x))
        return np.concatenate((error, prior_rows(x[:n_plain] * start))) if prior_rows.held else error

    x0 = np.concatenate((np.ones(n_plain), extra0))
    low = np.concatenate((np.full(n_plain, PLAIN_BOUNDS[0]), lower))
    high = np.concatenate((np.full(n_plain, PLAIN_BOUNDS[1]), upper))
    result = least_squares(rows, x0, bounds=(low, high), method="trf", x_scale="jac", diff_step=1e-6,
                           max_nfev=60, ftol=cost_tolerance(problem.n_fit), xtol=1e-7, gtol=1e-8,
                           **parallel_columns())
    angle = angle_of(result.x)
    return Rival(problem.fit_rss(problem.innovations(angle)), result.x[n_plain:], angle)
