"""The fits' Jacobian (fitting/secant.py): a secant update only after a fresh Jacobian whose
linear model predicted the step's gain, fresh differences otherwise, and a fresh one at the
solution, so that a fit's covariance never reads an update."""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares

from hand_service.diagnose.fitting.secant import SecantJacobian

BOUNDS = (np.full(2, -10.0), np.full(2, 10.0))


def _curved(x: np.ndarray) -> np.ndarray:
    """Rosenbrock's residual: curved enough that its linear model misses some steps."""
    return np.array([10.0 * (x[1] - x[0] ** 2), 1.0 - x[0]])


def test_an_update_follows_a_well_predicted_step_and_a_fresh_one_follows_an_update() -> None:
    jac = SecantJacobian(lambda x: np.array([2.0 * x[0] + x[1], x[0] - 3.0 * x[1] + 0.01 * x[0] ** 2]),
                         BOUNDS, 1e-6)
    first = jac(np.array([1.0, 1.0]))
    second = jac(np.array([0.5, 0.5]))  # nearly linear: the gain is as the first's model predicted
    third = jac(np.array([0.2, 0.2]))  # as well predicted, but after an update
    assert (jac.fresh_count, jac.secant_count) == (2, 1)
    assert np.allclose(first, [[2.0, 1.0], [1.02, -3.0]], atol=1e-5)
    assert np.allclose(second, [[2.0, 1.0], [1.01, -3.0]], atol=1e-2)  # the secant's, near the slope there
    assert not np.allclose(second, [[2.0, 1.0], [1.01, -3.0]], atol=1e-5)
    assert np.allclose(third, [[2.0, 1.0], [1.004, -3.0]], atol=1e-5)  # fresh: the slope at 0.2


def test_a_step_that_gains_nothing_gets_fresh_differences() -> None:
    jac = SecantJacobian(_curved, BOUNDS, 1e-6)
    jac(np.array([0.0, 0.0]))
    jac(np.array([3.0, 0.0]))  # far worse: the residual grew
    assert (jac.fresh_count, jac.secant_count) == (2, 0)


def test_the_fit_ends_where_fresh_differences_end_it_with_a_fresh_jacobian() -> None:
    x0 = np.array([-1.2, 1.0])
    plain = least_squares(_curved, x0, bounds=BOUNDS, method="trf", x_scale="jac", diff_step=1e-6,
                          xtol=1e-12, ftol=1e-12, gtol=1e-12)
    jac = SecantJacobian(_curved, BOUNDS, 1e-6)
    secant = least_squares(jac.rows, x0, jac=jac, bounds=BOUNDS, method="trf", x_scale="jac",
                           xtol=1e-12, ftol=1e-12, gtol=1e-12)
    final = jac.fresh_at(secant.x, secant.fun, secant.jac)
    assert np.allclose(secant.x, plain.x, atol=1e-6) and np.allclose(secant.x, [1.0, 1.0], atol=1e-6)
    assert jac.secant_count > 0
    exact = np.array([[-20.0 * secant.x[0], 10.0], [-1.0, 0.0]])
    assert np.allclose(final, exact, atol=1e-4)
