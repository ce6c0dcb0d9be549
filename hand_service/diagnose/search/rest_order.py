"""The search again with the noise filter's order from the finger at rest, kept where it
names more and the richer model follows the raw angle to the sensor's noise.

Every test of the search runs on innovations: the residual through an AR filter whose order
BIC chose on the plain model's misfit (residual/noise.py). Where that misfit is mostly
input-driven structure (two or three effects missing on steps, the misfit four to eight
times the noise at rest), BIC picks an order of 6 to 8 that predicts the structure from its
own past: the innovations come out near the sensor's noise, the first effect is found, and
those after it gain little (a valve lag named alone, with a quadratic damping and a dead
zone left to the filter). Re-choosing the order on the residual of the model with the first
effect in place does not help: what that model leaves is again structure, and BIC picks the
same order.

The sensor's own noise is where the finger is at rest (residual/noise_bound.py): there the
order is 2 or 3. Choosing it there for every recording is wrong the other way: a library
form that is a little off the physics (dry friction with a static peak) then leaves
structure the filter no longer takes, which stops the search after the first effect; and a
real rig's unmodelled dynamics show through. So the order at rest is asked only as a second
opinion, and only where the first search's model does not follow the raw angle to the
noise (raw_error.at_noise, simulated from the recorded command): the search runs again with
the order at rest, and its answer is kept only where it names every effect the first named
and more, and its model, simulated from the command alone, follows the raw angle to the
sensor's noise measured at rest (within raw_error's TIE_NOISE of it; the sample-to-sample
white noise is too small a yardstick for a sensor whose noise is correlated). The noise
model at rest then scores everything that follows (the set's members, the posture and
outside-library checks, the raw-signal gate judge it as any other).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from hand_service.diagnose.fitting import raw_error
from hand_service.diagnose.fitting.output_error import Fit
from hand_service.diagnose.model.problem import Problem
from hand_service.diagnose.residual import noise_bound
from hand_service.diagnose.residual.noise import NoiseModel
from hand_service.diagnose.search import set_search, tie_revisit
from hand_service.diagnose.search.forward_selection import Progress, Selection, select


@dataclass(frozen=True)
class AtRest:
    selection: Selection
    noise: NoiseModel  # the AR order and coefficients from the finger at rest
    order_before: int
    named_before: tuple[str, ...]
    raw_before_deg: float
    raw_deg: float
    noise_deg: float  # the sensor's noise at rest (RMS)

    def sentence(self) -> str:
        named = ", ".join(c.name for c in self.selection.accepted)
        before = ", ".join(self.named_before) or "nothing"
        return (f"the noise filter's order chosen on the plain model's misfit (AR {self.order_before}) "
                f"predicts the structure from its own past: with it, {before} was named, and the model "
                f"missed the raw angle by {self.raw_before_deg:.3g} deg RMS; with the order the sensor's "
                f"noise has where the finger is at rest (AR {self.noise.order}), the search names {named}, "
                f"which, simulated from the command, follow the raw angle to the sensor's noise at rest "
                f"({self.raw_deg:.3g} deg RMS against {self.noise_deg:.3g}), so the search at rest is kept")


def names(selection: Selection) -> set[str]:
    return {c.name for c in selection.accepted}


def search(problem: Problem, refit: Fit, selection: Selection, searched: list[str], valid: np.ndarray,
           scored: tuple[np.ndarray, np.ndarray], progress: Progress | None = None) -> AtRest | None:
    """The search again on innovations at the order at rest, or None (the first model is at the
    noise, no order at rest or none lower, or the second search names no more or does not
    reach the noise). `valid`: the samples the noise is estimated on; `scored`: the raw
    figures' fitting and held-out samples."""
    fitting, held = scored

    def raw_deg(angle_deg: np.ndarray) -> float:
        return raw_error.raw_rms_deg(problem, angle_deg, fitting, fitting | held)

    residual = refit.residual(problem)
    rest = noise_bound.rest_noise(residual, valid, problem.pressure_kpa, problem.rate_hz, refit.finger)
    if rest is None:
        return None
    rest_deg = float(np.sqrt(np.mean(rest * rest)))
    raw_before = raw_deg((selection.final or refit).angle_deg)
    if raw_error.at_noise(raw_before, rest_deg):
        return None
    at_rest = noise_bound.bounded_order(problem.noise, residual, problem.misfit(refit.angle_deg),
                                        valid, problem.pressure_kpa, problem.rate_hz, refit.finger)
    if at_rest.order >= problem.noise.order:
        return None
    if progress:
        progress(f"searching again with the noise filter's order at rest (AR {at_rest.order}, "
                 f"not {problem.noise.order})")
    again_problem = replace(problem, noise=at_rest)
    again = select(again_problem, refit, searched, progress)
    if (found_set := set_search.search(again_problem, again, progress)) is not None:
        again = found_set.selection
    if (tie := tie_revisit.revisit(again_problem, again, progress)) is not None:
        again = tie.selection
    if again.final is None or not names(again) > names(selection):
        return None
    raw_again = raw_deg(again.final.angle_deg)
    if not raw_error.at_noise(raw_again, rest_deg):
        return None
    return AtRest(again, at_rest, problem.noise.order, tuple(c.name for c in selection.accepted), raw_before,
                  raw_again, rest_deg)
