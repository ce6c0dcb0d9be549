"""Output-error least squares: simulate the finger on the recorded input, compare angles.

The simulator (rtcore_sim_run in C) is smooth in every parameter, including the dead
time, so scipy's trust-region reflective solver with finite-difference Jacobians works
directly on the simulated angles. Parameters are scaled by their typical magnitude and
kept within their plausible bounds.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from hand_service.diagnose.problem import Param, Problem
from rtcore.sim import SimFinger

DIVERGED_DEG = 1e4  # residual that stands for a simulation that ran away


@dataclass
class Fit:
    params: tuple[Param, ...]
    values: np.ndarray
    finger: SimFinger
    angle_deg: np.ndarray  # simulated, every sample
    rss_deg2: float  # residual sum of squares on the fitting samples (deg²)
    jacobian: np.ndarray  # d angle / d value on the fitting samples, physical units
    n_fit: int

    def residual(self, problem: Problem) -> np.ndarray:
        return problem.measured_deg - self.angle_deg

    @property
    def sigma_deg(self) -> float:
        """Noise estimate from the fitting residual, with the fitted degrees of freedom removed."""
        return float(np.sqrt(self.rss_deg2 / max(self.n_fit - len(self.params), 1)))

    def covariance(self) -> np.ndarray:
        """σ²·(JᵀJ)⁻¹, by pseudo-inverse so that a rank-deficient J shows as huge variance."""
        jtj = self.jacobian.T @ self.jacobian
        scale = np.sqrt(np.maximum(np.diag(jtj), 1e-300))
        normalised = jtj / np.outer(scale, scale)
        inverse = np.linalg.pinv(normalised, rcond=1e-12)
        cov = inverse / np.outer(scale, scale) * self.sigma_deg**2
        dead = np.diag(jtj) <= 1e-300
        cov[dead, :] = np.inf
        cov[:, dead] = np.inf
        return cov

    def std(self) -> np.ndarray:
        return np.sqrt(np.abs(np.diag(self.covariance())))

    def correlation(self) -> np.ndarray:
        cov = self.covariance()
        d = np.sqrt(np.abs(np.diag(cov)))
        with np.errstate(invalid="ignore", divide="ignore"):
            return cov / np.outer(d, d)

    def value(self, label: str) -> float:
        for p, v in zip(self.params, self.values, strict=True):
            if p.label == label:
                return float(v)
        raise KeyError(label)


def _scaled_bounds(params: Sequence[Param]) -> tuple[np.ndarray, np.ndarray]:
    return (np.array([p.lower / p.scale for p in params]), np.array([p.upper / p.scale for p in params]))


def _into_bounds(x: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    span = upper - lower
    return np.clip(x, lower + 1e-9 * span, upper - 1e-9 * span)


def fit(problem: Problem, params: Sequence[Param], start: Sequence[float], base: SimFinger | None = None,
        max_nfev: int = 60) -> Fit:
    """Least squares over `params` from `start`, everything else held at `base`."""
    params = tuple(params)
    scales = np.array([p.scale for p in params])
    lower, upper = _scaled_bounds(params)
    mask = problem.fit_mask

    def residual(x: np.ndarray) -> np.ndarray:
        angle = problem.simulate(problem.finger(params, x * scales, base))
        with np.errstate(invalid="ignore"):
            error = -problem.misfit(angle)[mask]
        # a finger driven unstable (strong softening, say) is a very bad fit, not a crash
        return np.where(np.isfinite(error), np.clip(error, -DIVERGED_DEG, DIVERGED_DEG), DIVERGED_DEG)

    x0 = _into_bounds(np.asarray(start, dtype=float) / scales, lower, upper)
    result = least_squares(residual, x0, bounds=(lower, upper), method="trf", x_scale="jac",
                           diff_step=1e-6, max_nfev=max_nfev, xtol=1e-8, ftol=1e-9, gtol=1e-9)
    values = result.x * scales
    finger = problem.finger(params, values, base)
    return Fit(params, values, finger, problem.simulate(finger), float(2.0 * result.cost),
               result.jac / scales, problem.n_fit)


def sensitivity(problem: Problem, param: Param, finger: SimFinger, angle_deg: np.ndarray) -> np.ndarray:
    """d angle / d value at `finger` (forward difference inside the bounds), every sample."""
    value = problem.values([param], finger)[0]
    step = 0.05 * param.scale
    if value + step > param.upper:
        step = -step
    moved = problem.simulate(problem.finger([param], [value + step], finger))
    return (moved - angle_deg) / step
