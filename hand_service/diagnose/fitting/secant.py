"""The Jacobian an output-error fit takes after each accepted step: new finite differences (one
simulation a parameter), or, where the step's gain was what the last fresh Jacobian's linear
model predicted, that Jacobian moved by Broyden's rank-one secant update (Broyden 1965):
J + (f − f₀ − J·Δx)·Δxᵀ/(Δxᵀ·Δx), no simulation at all. The update is taken only straight
after a fresh Jacobian, so every other one at most is a secant, and a step the linear model
mispredicted (the residual's curvature, a bound, a kink) always gets a fresh one. The fit's
final Jacobian, which its covariance and every standard error read, is fresh at the solution
(fresh_at). The fresh ones are scipy's own 2-point differences, the same steps and bounds
as least_squares' `diff_step` takes them."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.optimize._numdiff import approx_derivative

# the linear model's miss on the new residual, ‖f − f₀ − J·Δx‖², as a share of the step's
# gain, ‖f₀‖² − ‖f‖², below which the Jacobian is updated rather than simulated again
GOOD_PREDICTION = 0.1

Rows = Callable[[np.ndarray], np.ndarray]


class SecantJacobian:
    """least_squares' `jac` for `rows` (give the solver `self.rows` as its function): fresh
    2-point differences with relative step `step` inside `bounds`, or a secant update (the
    module's docstring). `columns`: approx_derivative's options (`workers`)."""

    def __init__(self, rows: Rows, bounds: tuple[np.ndarray, np.ndarray], step: float,
                 columns: dict | None = None) -> None:
        self._rows = rows
        self._bounds = bounds
        self._step = step
        self._columns = columns or {}
        self._last: tuple[bytes, np.ndarray] | None = None  # the last point the solver evaluated
        self._at: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None  # x, f, J of the last Jacobian
        self._fresh = False  # that Jacobian is finite differences, not an update
        self.fresh_count = 0
        self.secant_count = 0

    def rows(self, x: np.ndarray) -> np.ndarray:
        f = self._rows(x)
        self._last = (x.tobytes(), f)
        return f

    def _value(self, x: np.ndarray) -> np.ndarray:
        if self._last is not None and self._last[0] == x.tobytes():
            return self._last[1]
        return self.rows(x)

    def _differences(self, x: np.ndarray, f: np.ndarray) -> np.ndarray:
        self.fresh_count += 1
        return approx_derivative(self._rows, x, method="2-point", rel_step=self._step, f0=f,
                                 bounds=self._bounds, **self._columns)

    def __call__(self, x: np.ndarray) -> np.ndarray:
        f = self._value(x)
        jacobian = None
        if self._at is not None and self._fresh:
            x0, f0, j0 = self._at
            dx = x - x0
            missed = f - (f0 + j0 @ dx)
            gain = float(f0 @ f0 - f @ f)
            if gain > 0.0 and float(missed @ missed) < GOOD_PREDICTION * gain and float(dx @ dx) > 0.0:
                jacobian = j0 + np.outer(missed, dx) / float(dx @ dx)
                self.secant_count += 1
        self._fresh = jacobian is None
        if jacobian is None:
            jacobian = self._differences(x, f)
        self._at = (x.copy(), f.copy(), jacobian)
        return jacobian

    def fresh_at(self, x: np.ndarray, f: np.ndarray, jacobian: np.ndarray) -> np.ndarray:
        """The Jacobian at the solver's solution `x` (where the rows are `f`), fresh: the
        solver's own `jacobian` where it was fresh there, else new differences."""
        if self._fresh and self._at is not None and np.array_equal(self._at[0], x):
            return jacobian
        return self._differences(x, f)
