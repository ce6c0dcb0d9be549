"""What makes diagnose faster without changing its answer (hand_service/diagnose/model/problem.py,
fitting/output_error.py): a finger simulated again on the same recording comes from the problem's cache,
the same bit for bit; and a Jacobian's columns simulated side by side give the same fit,
bit for bit, as one at a time (HAND_DIAGNOSE_THREADS=1: diagnose/workers.py). (How much
faster: tests/bench/test_diagnose_benchmark.py.)"""

from __future__ import annotations

import dataclasses
import math
import os
import subprocess
import sys
import threading

import numpy as np
import pytest

from hand_service.diagnose import workers
from hand_service.diagnose.fitting.output_error import column_map, fit
from hand_service.diagnose.model.params import Param
from hand_service.diagnose.model.problem import PLAIN, Problem
from hand_service.diagnose.model.simulation_cache import SimulationCache, finger_key
from hand_service.diagnose.workers import MOST_THREADS, THREADS_ENV, thread_count
from tests.diagnose.linear_truth import stepped_recording

RATE_HZ = 100.0


def _problem(seed: int = 3) -> Problem:
    return stepped_recording(seed, 12.0, RATE_HZ, 0.8, {"valve_lag": {"tau_s": 0.02},
                                                        "dead_time": {"delay_s": 0.005}})


def _with_gravity(problem: Problem, torque_nm: float = 0.02):
    gravity = Param.effect("gravity")
    return problem.finger([gravity], [torque_nm])


def test_a_finger_simulated_again_comes_from_the_cache_the_same_bit_for_bit() -> None:
    problem = _problem()
    finger = _with_gravity(problem)
    first = problem.simulate(finger)
    again = problem.simulate(dataclasses.replace(finger))  # an equal finger, another object
    assert problem.simulations.hits == 1 and problem.simulations.misses == 1
    fresh = _problem().simulate(finger)  # another problem: its own cache, so a real run
    assert np.array_equal(first, fresh) and np.array_equal(again, fresh)


def test_each_caller_gets_its_own_copy_of_a_cached_angle() -> None:
    problem = _problem()
    finger = _with_gravity(problem)
    first = problem.simulate(finger)
    expected = first.copy()
    first[:] = np.nan  # a caller that writes into its angle does not change the next one's
    assert np.array_equal(problem.simulate(finger), expected)


def test_a_finger_one_bit_apart_is_simulated_anew() -> None:
    problem = _problem()
    finger = _with_gravity(problem)
    problem.simulate(finger)
    k = finger.prbm.stiffness_nm_per_rad
    stiffer = dataclasses.replace(finger.prbm, stiffness_nm_per_rad=math.nextafter(k, 1.0))
    nudged = dataclasses.replace(finger, prbm=stiffer)
    problem.simulate(nudged)
    assert problem.simulations.misses == 2 and problem.simulations.hits == 0
    signed = dataclasses.replace(finger, contact_angle_deg=-0.0)  # −0.0 and 0.0 are two keys
    assert finger.contact_angle_deg == 0.0 and finger_key(signed) != finger_key(finger)
    warmer = dataclasses.replace(finger, pneumatic=dataclasses.replace(finger.pneumatic, temperature_k=300.0))
    assert finger_key(warmer) != finger_key(finger)  # every nested field counts


def test_the_key_names_every_field_of_the_finger() -> None:
    finger = _with_gravity(_problem())
    leaves = []
    stack = [finger]
    while stack:  # every field that is not itself a dataclass, at any depth
        obj = stack.pop()
        for f in dataclasses.fields(obj):
            value = getattr(obj, f.name)
            (stack if dataclasses.is_dataclass(value) else leaves).append(value)
    assert sorted(finger_key(finger)) == sorted(repr(v) for v in leaves)


def test_a_copy_of_the_problem_with_another_command_does_not_use_the_cache() -> None:
    problem = _problem()
    finger = _with_gravity(problem)
    problem.simulate(finger)
    other = dataclasses.replace(problem, pressure_kpa=np.ascontiguousarray(problem.pressure_kpa[::-1]))
    assert other.simulations is problem.simulations  # the copies share it ...
    reversed_run = other.simulate(finger)
    alone = dataclasses.replace(_problem(), pressure_kpa=other.pressure_kpa)
    assert np.array_equal(reversed_run, alone.simulate(finger))  # ... but only for their command
    assert not np.array_equal(reversed_run, problem.simulate(finger))


def test_the_cache_drops_the_least_recently_used_past_its_budget() -> None:
    cache = SimulationCache(budget_bytes=3 * 80)
    for i in range(4):
        cache.put(i, np.full(10, float(i)))  # 80 bytes each
        if i == 2:
            assert cache.get(0) is not None  # 0 used again: 1 is now the oldest
    assert len(cache) == 3
    assert cache.get(1) is None
    assert [float(cache.get(i)[0]) for i in (0, 2, 3)] == [0.0, 2.0, 3.0]


def test_a_fit_is_the_same_with_its_jacobian_columns_side_by_side() -> None:
    params = [Param.plain(name, v) for name, v in zip(PLAIN, (0.45, 0.003, 0.0119), strict=True)]
    fits = {}
    for jobs in (1, 2):
        with workers.using(jobs):
            problem = _problem()  # a fresh cache each time: every simulation runs
            fits[jobs] = fit(problem, [*params, Param.effect("gravity")], [0.45, 0.003, 0.0119, 0.01])
    one, two = fits[1], fits[2]
    assert np.array_equal(one.values, two.values) and np.array_equal(one.jacobian, two.jacobian)
    assert one.rss_deg2 == two.rss_deg2 and np.array_equal(one.angle_deg, two.angle_deg)
    start = _problem()
    start_rss = float(np.sum(start.misfit(start.simulate(start.base))[start.fit_mask] ** 2))
    assert one.rss_deg2 < 0.5 * start_rss  # the fit went somewhere: many Jacobians were taken


def test_column_map_keeps_the_order_and_uses_other_threads() -> None:
    if workers.threads() < 2:
        pytest.skip("one core: the columns run one at a time")
    threads: set[int] = set()
    barrier = threading.Barrier(2, timeout=30.0)

    def column(x: np.ndarray) -> np.ndarray:
        threads.add(threading.get_ident())
        if x[0] < 2.0:
            barrier.wait()  # the first two columns must be running at once to pass here
        return 10.0 * x

    out = list(column_map(column, (np.array([float(i)]) for i in range(5))))
    assert [float(v[0]) for v in out] == [0.0, 10.0, 20.0, 30.0, 40.0]
    assert len(threads) >= 2


def test_the_environment_sets_diagnose_s_threads() -> None:
    cores = max(1, min(MOST_THREADS, os.cpu_count() or 1))
    assert thread_count({}) == cores
    assert thread_count({THREADS_ENV: "1"}) == 1
    assert thread_count({THREADS_ENV: " 2 "}) == 2
    assert thread_count({THREADS_ENV: "64"}) == MOST_THREADS
    for wrong in ("0", "-1", "two", "1.5"):
        with pytest.raises(ValueError, match=THREADS_ENV):
            thread_count({THREADS_ENV: wrong})


def test_one_thread_asked_runs_every_pool_serially() -> None:
    code = ("from hand_service.diagnose.fitting import output_error as f\n"
            "from hand_service.diagnose.search import forward_selection as s\n"
            "from hand_service.diagnose import workers as w\n"
            "print(w.threads())")
    env = {**os.environ, THREADS_ENV: "1"}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["1"]
