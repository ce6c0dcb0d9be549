"""The nominal's prior in the search's evidence: its χ² (what it adds to a fit's BIC) and an
accepted effect's ΔBIC with k, B and N free of it (what the data alone say)."""

from __future__ import annotations

import dataclasses

from hand_service.diagnose.fitting.output_error import Fit, fit
from hand_service.diagnose.model.problem import NO_PRIOR, Problem
from hand_service.diagnose.residual import stats


def prior_chi2(problem: Problem, f: Fit) -> float:
    """The nominal's log-normal prior as a χ² (−2 ln prior, up to a constant): the term it
    adds to the BIC of a fit that held k, B and N near the nominal."""
    weight = problem.prior.weight_deg
    return f.prior_cost_deg2 / weight**2 if weight > 0.0 else 0.0


def data_alone_bic(problem: Problem, refit: Fit, accepted: Fit) -> float:
    """ΔBIC of an accepted effect (its joint fit `accepted`) with k, B and N free of the
    nominal's prior, the model without and with it each refitted so. Where the recording
    cannot pin k, B and N and the prior holds them, an effect may win only because it does
    what the prior keeps them from doing: on a slow ramp a valve lag delays the finger as
    extra damping B would."""
    free = dataclasses.replace(problem, prior=NO_PRIOR)
    without = fit(free, refit.params, refit.values, base=refit.finger)
    with_effect = fit(free, accepted.params, accepted.values, base=refit.finger)
    return stats.delta_bic(free.fit_rss(free.innovations(without.angle_deg)),
                           free.fit_rss(free.innovations(with_effect.angle_deg)), free.n_fit)
