"""The joint fits' numerics (hand_service/diagnose/search/forward_selection.py): k, B and N kept within
JOINT_RANGE of the refit and the nominal, a candidate never scored worse than no effect
at all, and the same answer whether the effects are fitted one at a time or side by side."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from hand_service.diagnose import workers
from hand_service.diagnose.fitting.output_error import fit
from hand_service.diagnose.model.params import Param
from hand_service.diagnose.model.problem import PLAIN
from hand_service.diagnose.residual import noise
from hand_service.diagnose.search import forward_selection as search
from hand_service.diagnose.search import joint_start
from tests.diagnose.linear_truth import lab_sensor_noise, quantise, stepped_recording

RATE_HZ = 100.0


def _problem(seed: int = 4):
    problem = stepped_recording(seed, 20.0, RATE_HZ, 0.5)  # the refit doubles k
    nominal = problem.base.prbm
    params = [Param.plain(name, getattr(nominal, name)) for name in PLAIN]
    return problem, fit(problem, params, problem.values(params))


def test_a_joint_fit_keeps_k_b_n_within_its_range_of_the_refit_and_the_nominal() -> None:
    problem, refit = _problem()
    nominal = problem.values(refit.params)
    assert refit.value("stiffness_nm_per_rad") == pytest.approx(2.0 * nominal[0], rel=0.05)
    for p, value, centre in zip(joint_start.joint_range(problem, refit), refit.values, nominal, strict=True):
        assert math.isclose(p.lower, min(value, centre) / joint_start.JOINT_RANGE)
        assert math.isclose(p.upper, max(value, centre) * joint_start.JOINT_RANGE)
        assert p.lower < min(value, centre) and max(value, centre) < p.upper  # both starts inside


def test_a_candidate_is_never_scored_far_worse_than_no_effect() -> None:
    """A start that lands in a worse basin (here forced: a dead zone above every command)
    is not the candidate's score: the fit from the effect's neutral value is."""
    problem, refit = _problem()
    screened = search.screen(problem, refit, "pressure_deadzone")
    screened.starts[:] = [0.95 * screened.param.upper]  # the command never passes it
    sigma = problem.innovation_sigma(problem.innovations(refit.angle_deg), len(refit.params))
    candidate = search.score(problem, refit, screened, sigma, thorough=False)
    assert candidate.delta_bic > -2.0 * math.log(problem.n_fit)
    assert candidate.estimate < 0.1 * screened.param.upper


def test_the_effects_fitted_side_by_side_give_the_same_round() -> None:
    problem, refit = _problem()
    rounds = {}
    for jobs in (1, 2):
        with workers.using(jobs):
            rounds[jobs] = search.run_round(problem, refit, ["coulomb_friction", "cubic_stiffness",
                                                             "valve_lag"], None, fit_all=True)
    one, two = ([(c.name, c.estimate, c.delta_bic) for c in rounds[w].candidates] for w in (1, 2))
    assert one == two


def _lab_problem(seed: int = 4):
    """_problem's recording with a lab sensor's noise added (correlated over 0.1 s, a
    drifting offset, ADC steps) and the noise model estimated as diagnose does."""
    problem = stepped_recording(seed, 20.0, RATE_HZ, 0.5)
    extra, adc_deg = lab_sensor_noise(np.random.default_rng(seed + 100), problem.measured_deg.size, RATE_HZ)
    problem = dataclasses.replace(problem, measured_deg=quantise(problem.measured_deg + extra, adc_deg))
    params = [Param.plain(name, getattr(problem.base.prbm, name)) for name in PLAIN]
    first = fit(problem, params, problem.values(params))
    problem.noise = noise.estimate(first.residual(problem),
                                   problem.with_skipped(problem.fit_mask | problem.held_mask), RATE_HZ)
    return problem, fit(problem, params, first.values)


def test_a_later_round_fits_only_what_the_screen_predicts_a_gain_for(monkeypatch) -> None:
    """After the first round, of the screen's best three only the effects whose best
    linearised point gains ΔBIC on the innovations are fitted (search.LATER_WHITE_BIC): on
    a plain finger's recording with a lab sensor's correlated noise (an AR noise model, so
    the prediction is taken through its filter) none of the four gains there, and none is
    fitted; with the bar lowered below every prediction the best three are."""
    problem, refit = _lab_problem()
    assert problem.noise.order > 0  # the innovations are not the raw residual
    names = ["coulomb_friction", "cubic_stiffness", "valve_lag", "gravity"]
    screens = sorted((search.screen(problem, refit, n) for n in names), key=lambda s: -s.predicted_bic)
    assert all(s.predicted_white_bic <= search.LATER_WHITE_BIC for s in screens)
    fitted: list[str] = []
    score = search.score

    def spy(problem, base, screened, *args, **kwargs):
        fitted.append(screened.name)
        return score(problem, base, screened, *args, **kwargs)

    monkeypatch.setattr(search, "score", spy)
    assert search.run_round(problem, refit, names, None, fit_all=False).candidates == []
    assert fitted == []
    monkeypatch.setattr(search, "LATER_WHITE_BIC", min(s.predicted_white_bic for s in screens) - 1.0)
    search.run_round(problem, refit, names, None, fit_all=False)
    assert sorted(fitted) == sorted(s.name for s in screens[: search.LATER_TOP])


def test_a_sensitivity_that_overflowed_leaves_its_parameter_unknown_not_a_traceback() -> None:
    """N of 1e-300 made its column 1e300 and JᵀJ infinite: numpy's SVD did not converge and
    diagnose ended in a traceback. That parameter's variance is infinite, the others' as
    before."""
    _, refit = _problem()
    broken = dataclasses.replace(refit, jacobian=refit.jacobian.copy())
    broken.jacobian[:, 2] *= 1e300
    std = broken.std()
    assert np.isinf(std[2]) and np.all(np.isfinite(std[:2]))
    before = dataclasses.replace(refit, jacobian=np.delete(refit.jacobian, 2, axis=1),
                                 params=refit.params[:2], values=refit.values[:2])
    assert np.allclose(std[:2], before.std(), rtol=1e-3)  # σ² counts one parameter more
