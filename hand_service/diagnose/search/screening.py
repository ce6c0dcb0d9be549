"""The screen: what one simulation per point says about an effect before any joint fit.

For each library effect the model leaves out: its signature (the angle's sensitivity to
the effect's parameter, with what k, B and N can absorb projected out), whose correlation
with the residual is the score (Lagrange multiplier) test, and a scan over a logarithmic
grid of the effect's values on both sides of neutral, k, B and N readjusted linearly at
each point. Together they rank the effects and give each joint fit its starts (forward_selection.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hand_service.config import effects as fx
from hand_service.diagnose.fitting.output_error import Fit, sensitivity
from hand_service.diagnose.model.params import EffectScales, Param
from hand_service.diagnose.model.problem import Problem
from hand_service.diagnose.residual import noise, stats


def project_out(jacobian: np.ndarray, signal: np.ndarray) -> np.ndarray:
    coeffs, *_ = np.linalg.lstsq(jacobian, signal, rcond=None)
    return signal - jacobian @ coeffs


def start_value(param: Param, neutral: float, step: float) -> float:
    """The Gauss-Newton guess, kept inside the bounds and off a bound it would stick to."""
    value = neutral + step
    if value <= param.lower:
        value = param.lower + 0.1 * param.scale
    return float(min(value, param.upper - 1e-9 * (param.upper - param.lower)))


SCAN_SPAN = np.geomspace(0.03, 30.0, 13)  # deviations from neutral, in units of the effect's scale
SCAN_STRIDES = (4, 2, 1)  # the grid's points at a factor of 10 apart first, then halved twice about the best
# Effects whose cost along a side of the grid is not one valley: a dead zone wider than every
# command stops the finger, a plateau beyond the commands that the coarse points can straddle
# (coarse to fine, the dead zone's scan can end well above the grid's best cost): every point
# of the grid.
WHOLE_GRID = frozenset({"pressure_deadzone"})


@dataclass
class Screen:
    """What one simulation per grid point says about an effect, before any joint fit."""

    name: str
    param: Param
    signature_corr: float
    separability: float
    starts: list[float]
    predicted_bic: float  # ΔBIC if k, B, N readjusted linearly: a cheap stand-in for the fit
    predicted_white_bic: float  # the same on the innovations (the noise's AR filter)


def scan(problem: Problem, base: Fit, param: Param, neutral: float,
         basis: np.ndarray) -> tuple[float, float, np.ndarray | None]:
    """The effect value whose residual, after the best linear readjustment of the model's
    own parameters, is smallest over a logarithmic grid on both sides of neutral, and that
    residual's sum of squares, to start the joint fit in the right basin (the joint fit of
    dry friction, for one, has a second minimum where B absorbs part of it).

    One simulation per point, coarse to fine: every fourth point of the grid on each side
    (a factor of 10 apart), then the best point's neighbours at half the stride, twice:
    12 of the grid's 26 points. Along one side the cost falls to one minimum and rises
    again, so the search ends where the whole grid would (but for WHOLE_GRID's effects,
    scanned whole); after the first effect is accepted every simulation carries it, and
    dry friction's cost ten times as much. `basis`: readjustment_basis(base)."""
    mask = problem.fit_mask
    costs: dict[tuple[int, int], float] = {}
    residuals: dict[tuple[int, int], np.ndarray] = {}  # the fitting samples' misfits, readjusted

    def cost(side: int, index: int) -> float:
        if not 0 <= index < len(SCAN_SPAN):
            return np.inf
        if (side, index) not in costs:
            value = neutral + side * SCAN_SPAN[index] * param.scale
            costs[side, index] = np.inf
            if param.lower < value < param.upper:
                angle = problem.simulate(problem.finger([param], [value], base.finger))
                with np.errstate(invalid="ignore"):  # a point driving the finger unstable: NaN, never best
                    r = problem.misfit(angle)[mask]
                    r -= basis @ (basis.T @ r)
                    c = float(r @ r)
                costs[side, index] = c if np.isfinite(c) else np.inf
                residuals[side, index] = r
        return costs[side, index]

    strides = (1,) if param.label in WHOLE_GRID else SCAN_STRIDES
    best = min(((side, i) for side in (1, -1) for i in range(0, len(SCAN_SPAN), strides[0])),
               key=lambda key: cost(*key))
    for stride in strides[1:]:
        side, i = best
        best = min((best, (side, i - stride), (side, i + stride)), key=lambda key: cost(*key))
    if not np.isfinite(cost(*best)):
        return neutral, np.inf, None
    side, i = best
    return float(neutral + side * SCAN_SPAN[i] * param.scale), cost(*best), residuals[best]


def readjustment_basis(base: Fit) -> np.ndarray:
    """An orthonormal basis of what the model's own parameters change on the fitting
    samples (the columns of base's Jacobian): the linear readjustment projects it out."""
    return np.linalg.qr(base.jacobian)[0]


def white_rss(problem: Problem, residual: np.ndarray) -> float:
    """The sum of squares of a fitting-sample residual (readjusted) through its own AR filter
    of the noise model's order, as Problem.innovations takes a model's: estimated on the
    fitting samples and run over the recording's own time, the held-out samples left at 0
    (their misfit is not readjusted, and joining the fitting samples end to end would
    make a lag across a held-out block a lag of one sample)."""
    full = np.zeros(problem.fit_mask.size)
    full[problem.fit_mask] = residual
    e = noise.prewhiten(full, problem.noise.order, full[problem.with_skipped(problem.fit_mask)])
    e = e[problem.fit_mask]
    return float(e @ e)


def screen(problem: Problem, base: Fit, name: str) -> Screen:
    """The effect's signature against the residual (score test) and the grid scan."""
    spec = fx.BY_NAME[name]
    prbm = base.finger.prbm
    param = Param.effect(name, EffectScales.of(
        float(prbm.stiffness_nm_per_rad), float(prbm.pressure_gain_nm_per_kpa), problem.pressure_kpa,
        base.angle_deg, problem.rate_hz))
    mask = problem.fit_mask
    residual = problem.misfit(base.angle_deg)[mask]
    # what the sensor's offset and drift would absorb of the signature does not count
    signature = problem.noise.detrend(sensitivity(problem, param, base.finger, base.angle_deg))[mask]
    projected = project_out(base.jacobian, signature)
    norm = float(np.sqrt(projected @ projected))
    raw = float(np.sqrt(signature @ signature))
    r = residual - residual.mean()
    corr = float(projected @ r) / (norm * float(np.sqrt(r @ r))) if norm > 0 and r.any() else 0.0
    step = float(projected @ residual) / norm**2 if norm > 0 else 0.0
    starts = [start_value(param, spec.neutral, step)]
    basis = readjustment_basis(base)
    scanned, scan_rss_deg2, scanned_residual = scan(problem, base, param, spec.neutral, basis)
    if abs(scanned - starts[0]) > 0.2 * abs(starts[0] - spec.neutral) + 1e-12:
        starts.append(scanned)
    linear_rss_deg2 = base.rss_deg2 * (1.0 - corr**2)  # the Gauss-Newton step's prediction
    best_rss_deg2 = max(min(scan_rss_deg2, linear_rss_deg2), 1e-300)
    predicted = stats.delta_bic(base.rss_deg2, best_rss_deg2, problem.n_fit)
    # the same on the innovations, whose ΔBIC decides: correlated noise inflates the raw one
    # (it predicted 1 882 for a dead zone whose fit lost 15)
    base_r = residual - basis @ (basis.T @ residual)
    after = [white_rss(problem, base_r - step * projected)] if norm > 0 else []
    if scanned_residual is not None:
        after.append(white_rss(problem, scanned_residual))
    white = stats.delta_bic(max(white_rss(problem, base_r), 1e-300), max(min(after), 1e-300),
                            problem.n_fit) if after else -np.inf
    return Screen(name, param, corr, norm / raw if raw > 0 else 0.0, starts, predicted, white)
