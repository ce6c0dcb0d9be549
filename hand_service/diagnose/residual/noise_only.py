"""What a claim that a model leaves noise only must pass beyond white innovations.

`consistent` and `parameters_only` say the refitted plain model leaves the sensor's noise;
`missing_physics` graded `complete` says the same of the model with the named effects. The
AR noise model, fitted on the plain model's residual, can take smooth input-driven structure
for correlated noise, so white innovations alone do not make the claim. Each measure of the
noise that does not rest on the AR filter is asked in turn, where the recording allows it:

- the noise where the finger is at rest (residual/noise_bound.py), or where the recording
  has no stretch at rest, what of the misfit no torque driven by the command and the motion
  makes (residual/driven_noise.py);
- the misfit's growth with the finger's motion (residual/motion_structure.py);
- for a named model, what repeats with a repeating command (residual/periodic_structure.py).

Each answer is a sentence saying what remains, or '' where none finds structure.
"""

from __future__ import annotations

import numpy as np

from hand_service.diagnose.fitting.output_error import Fit
from hand_service.diagnose.model.problem import Problem
from hand_service.diagnose.residual import driven_noise, motion_structure, noise_bound, periodic_structure


def plain_structure(problem: Problem, refit: Fit, residual_deg: np.ndarray, valid: np.ndarray) -> str:
    """What says the refitted plain model (`residual_deg` its raw residual) leaves more than
    noise: '' where nothing does, so that `consistent` or `parameters_only` may stand."""
    return _at_rest_or_moving(problem, refit, residual_deg, valid, graded=False)


def named_structure(problem: Problem, final: Fit, valid: np.ndarray) -> str:
    """What says the model with the named effects leaves more than noise, though its
    innovations are white: '' where nothing does, so that its grade may be `complete`."""
    repeats = periodic_structure.periodic(problem.misfit(final.angle_deg), valid, problem.pressure_kpa,
                                          problem.rate_hz)
    if repeats is not None and repeats.exceeded:
        return repeats.sentence()
    return _at_rest_or_moving(problem, final, problem.residual(final.angle_deg), valid, graded=True)


def _at_rest_or_moving(problem: Problem, model: Fit, residual_deg: np.ndarray, valid: np.ndarray,
                       graded: bool) -> str:
    """The noise at rest against the misfit (the grade's lower factor where `graded`), or
    without a stretch at rest the noise no driven torque makes; then the misfit's growth
    with the motion."""
    misfit = problem.misfit(model.angle_deg)
    rest = noise_bound.bound(residual_deg, misfit, valid, problem.pressure_kpa, problem.rate_hz, model.finger)
    if rest is not None and (rest.exceeds_grade if graded else rest.exceeded):
        return rest.grade_sentence() if graded else rest.sentence()
    if rest is None:
        driven = driven_noise.driven_noise(misfit, model.angle_deg, problem.pressure_kpa, valid,
                                           problem.rate_hz, model.finger)
        factor = noise_bound.GRADE_FACTOR if graded else noise_bound.STRUCTURE_FACTOR
        if driven is not None and driven.exceeds(factor):
            return driven.sentence(named=graded)
    moving = motion_structure.motion_structure(misfit, model.angle_deg, valid, problem.rate_hz)
    return moving.sentence() if moving is not None and moving.exceeded else ""


__all__ = ["named_structure", "plain_structure"]
