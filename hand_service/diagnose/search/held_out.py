"""The held-out data asked again: a second, disjoint quarter for a candidate whose one
quarter is borderline, and the z a real effect of a candidate's gain would show there
(forward_selection.score and second_look ask them)."""

from __future__ import annotations

from typing import Protocol

import numpy as np

from hand_service.diagnose.fitting.output_error import Fit, fit
from hand_service.diagnose.model.problem import Problem
from hand_service.diagnose.residual import stats


class Gained(Protocol):
    """What of a candidate (forward_selection.Candidate) expected_z reads."""

    fit: Fit
    delta_bic: float
    prior_gain: float


def second_split_z(problem: Problem, base: Fit, joint: Fit) -> float:
    """The held-out z on a second, disjoint quarter of the blocks (Problem.rotated), the
    model without and with the effect each refitted on the other three quarters. For a
    borderline candidate: a real effect of ΔBIC 30 to 100 expects z of only 1.6 to 2.9 on
    one quarter, and misses the bar half the time; the two quarters' z together,
    (z₁ + z₂)/√2, have the same null distribution as one and twice the held-out data."""
    other = problem.rotated()
    without = fit(other, base.params, base.values, base=base.finger)
    with_effect = fit(other, joint.params, joint.values, base=base.finger)
    held = other.held_mask
    before = other.innovations(without.angle_deg)
    sigma = other.innovation_sigma(before, len(without.params))
    return stats.heldout_z_innovations(before[held], other.innovations(with_effect.angle_deg)[held], sigma)


def expected_z(problem: Problem, base: Fit, candidate: Gained) -> float:
    """The held-out z a real effect of the candidate's fitted gain would show, were its gain
    spread as evenly over the held-out blocks as over the fitted ones: z ≈ ‖δ‖/2σ on the
    held-out samples, with ‖δ‖²/σ² the fitted samples' gain (ΔBIC, its penalty added back
    and the nominal's prior taken out: the data's share) scaled by their numbers."""
    extra = len(candidate.fit.params) - len(base.params)
    gain = max(candidate.delta_bic - candidate.prior_gain + extra * np.log(problem.n_fit), 0.0)
    return float(0.5 * np.sqrt(gain * problem.held_mask.sum() / problem.fit_mask.sum()))
