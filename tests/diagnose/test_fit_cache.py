"""A recording's fits kept and found again (hand_service/diagnose/model/fit_cache.py,
fitting/output_error.fit): the search at the noise filter's order at rest asks the first
search's fits again, and must not run their simulations a second time."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hand_service.diagnose.fitting.output_error import fit
from hand_service.diagnose.model.fit_cache import FitCache
from hand_service.diagnose.model.params import Param
from hand_service.diagnose.model.problem import PLAIN, Prior, Problem
from hand_service.diagnose.residual import noise
from tests.diagnose.linear_truth import stepped_recording

RATE_HZ = 100.0
START = [0.45, 0.003, 0.0119, 0.01]


def _problem() -> Problem:
    problem = stepped_recording(3, 12.0, RATE_HZ, 0.8, {"valve_lag": {"tau_s": 0.02}})
    problem.noise = noise.nuisance_only(problem.measured_deg.size, RATE_HZ)
    return problem


def _params() -> list[Param]:
    return [*(Param.plain(name, v) for name, v in zip(PLAIN, START, strict=False)), Param.effect("gravity")]


def _runs(problem: Problem) -> int:
    return problem.simulations.misses + problem.simulations.hits


def test_a_fit_at_another_noise_order_is_found_again_without_a_simulation() -> None:
    problem = _problem()
    first = fit(problem, _params(), START)
    runs = _runs(problem)
    assert runs > 20  # the fit itself simulated: Jacobians and steps
    at_rest = dataclasses.replace(problem, noise=dataclasses.replace(problem.noise, order=3))
    again = fit(at_rest, _params(), list(START))
    assert _runs(problem) == runs  # not one simulation, not even from the simulation cache
    assert again is first and problem.fits.hits == 1
    fresh = fit(_problem(), _params(), START)  # another recording's problem: its own cache, a real fit
    assert np.array_equal(fresh.values, first.values) and fresh.rss_deg2 == first.rss_deg2
    assert np.array_equal(fresh.angle_deg, first.angle_deg) and np.array_equal(fresh.jacobian, first.jacobian)


def test_a_kept_fit_cannot_be_changed_by_a_caller() -> None:
    kept = fit(_problem(), _params(), START)
    with pytest.raises(ValueError):
        kept.angle_deg[0] = 0.0
    with pytest.raises(ValueError):
        kept.values[0] = 0.0


@pytest.mark.parametrize("change", ["start", "fit_mask", "prior", "basis", "measured"])
def test_anything_the_fit_reads_changed_fits_anew(change: str) -> None:
    problem = _problem()
    fit(problem, _params(), START)
    start = list(START)
    if change == "start":
        start[3] = np.nextafter(start[3], 1.0)
    elif change == "fit_mask":
        problem = problem.rotated()
    elif change == "prior":
        problem = dataclasses.replace(problem, prior=Prior({"stiffness_nm_per_rad": 0.45},
                                                           {"stiffness_nm_per_rad": 0.25}, 0.3))
    elif change == "basis":  # an equal basis, another object: the cache asks identity
        problem = dataclasses.replace(problem, noise=dataclasses.replace(problem.noise,
                                                                         basis=problem.noise.basis.copy()))
    else:
        problem = dataclasses.replace(problem, measured_deg=problem.measured_deg + 0.0)
    runs = _runs(problem)
    fit(problem, _params(), start)
    assert problem.fits.hits == 0 and _runs(problem) > runs


def test_the_fit_cache_drops_the_least_recently_used_past_its_budget() -> None:
    cache = FitCache(budget_bytes=300)
    anchor = np.zeros(1)
    for i in range(4):
        cache.put(i, (anchor,), f"fit {i}", 100)
        if i == 2:
            assert cache.get(0, (anchor,)) == "fit 0"  # 0 used again: 1 is now the oldest
    assert len(cache) == 3 and cache.get(1, (anchor,)) is None
    assert cache.get(3, (np.zeros(1),)) is None  # an equal array, another object: not served
