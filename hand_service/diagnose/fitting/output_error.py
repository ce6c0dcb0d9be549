"""Output-error least squares: simulate the finger on the recorded input, compare angles.

The simulator (rtcore_sim_run in C) is smooth in every parameter, including the dead
time, so scipy's trust-region reflective solver with finite-difference Jacobians works
directly on the simulated angles. Parameters are scaled by their typical magnitude and
kept within their plausible bounds.

A Jacobian's columns are independent simulations: they run side by side on the machine's
cores (the C simulator runs without Python's lock), taken in column order, so the
Jacobian and every fit are the same, bit for bit, as one column at a time.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from hand_service.config import effects as fx
from hand_service.diagnose.model.params import Param
from hand_service.diagnose.model.problem import PRIOR_RELATIVE_WIDTH, Prior, Problem
from hand_service.diagnose.model.simulation_cache import finger_key
from hand_service.diagnose.workers import ordered_map
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
    # the prior's information on each parameter (deg² per unit², 0 without a prior) and
    # its share of the cost: the nominal model's uncertainty, when the problem has one
    prior_information: np.ndarray | None = None
    prior_cost_deg2: float = 0.0

    def without(self, problem: Problem, names: Iterable[str]) -> SimFinger:
        """This fit's finger with its effects `names` at their neutral values: left out."""
        left_out = set(names)
        params = [p for p in self.params if p.label in left_out and p.is_size]
        return problem.finger(params, [fx.BY_NAME[p.label].neutral for p in params], self.finger)

    @property
    def cost_deg2(self) -> float:
        """What the fit minimised: the residual's squares and the prior's."""
        return self.rss_deg2 + self.prior_cost_deg2

    def residual(self, problem: Problem) -> np.ndarray:
        return problem.residual(self.angle_deg)

    @property
    def sigma_deg(self) -> float:
        """Noise estimate from the fitting residual, with the fitted degrees of freedom removed."""
        return float(np.sqrt(self.rss_deg2 / max(self.n_fit - len(self.params), 1)))

    def covariance(self, with_prior: bool = True) -> np.ndarray:
        """σ²·(JᵀJ + P)⁻¹, P the prior's information; by pseudo-inverse so that a
        rank-deficient J shows as huge variance. Without the prior: what the data alone say."""
        with np.errstate(over="ignore", invalid="ignore"):
            jtj = self.jacobian.T @ self.jacobian
        if with_prior and self.prior_information is not None:
            jtj = jtj + np.diag(self.prior_information)
        # a parameter whose sensitivity overflowed (a model far out of its units) says nothing
        live = (np.diag(jtj) > 1e-300) & np.isfinite(np.diag(jtj))
        cov = np.full(jtj.shape, np.inf)
        if live.any():
            block = jtj[np.ix_(live, live)]
            scale = np.sqrt(np.diag(block))
            inverse = np.linalg.pinv(block / np.outer(scale, scale), rcond=1e-12)
            cov[np.ix_(live, live)] = inverse / np.outer(scale, scale) * self.sigma_deg**2
        return cov

    def std(self, with_prior: bool = True) -> np.ndarray:
        return np.sqrt(np.abs(np.diag(self.covariance(with_prior))))

    def correlation(self) -> np.ndarray:
        cov = self.covariance()
        d = np.sqrt(np.abs(np.diag(cov)))
        with np.errstate(invalid="ignore", divide="ignore"):
            return cov / np.outer(d, d)

    def value(self, label: str, member: str = "") -> float:
        """A parameter's value: plain, an effect's first (`label` its name) or one of its
        shape (`member`)."""
        for p, v in zip(self.params, self.values, strict=True):
            if p.label == label and p.member == member:
                return float(v)
        raise KeyError(label)

    def shape(self, name: str) -> dict[str, float]:
        """Effect `name`'s fitted shape parameters (none when only its size was fitted)."""
        return {p.member: float(v) for p, v in zip(self.params, self.values, strict=True)
                if p.label == name and p.member}


def _scaled_bounds(params: Sequence[Param]) -> tuple[np.ndarray, np.ndarray]:
    return (np.array([p.lower / p.scale for p in params]), np.array([p.upper / p.scale for p in params]))


def _into_bounds(x: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    span = upper - lower
    return np.clip(x, lower + 1e-9 * span, upper - 1e-9 * span)


# least_squares takes `workers` from SciPy 1.16 on; before, the columns run one at a time
_PARALLEL_COLUMNS = "workers" in inspect.signature(least_squares).parameters


def column_map(function: Callable[[np.ndarray], np.ndarray],
               points: Iterable[np.ndarray]) -> Iterator[np.ndarray]:
    """map() for scipy's finite differences (least_squares' `workers`): the points on
    diagnose's shared threads (workers.ordered_map: the first in the calling thread, none
    beyond the threads in force, however many fits run at once); results in order."""
    return iter(ordered_map(function, points))


def parallel_columns() -> dict:
    """least_squares' option that simulates a Jacobian's columns side by side, where SciPy has it."""
    return {"workers": column_map} if _PARALLEL_COLUMNS else {}


# A fit stops once an iteration gains less than this share of the noise's variance in the
# residual's sum of squares, about as much of a ΔBIC. A fixed relative tolerance of 1e-7
# spent some 60 % of a fit's simulations after its cost had come within 1e-4 of where it
# ended (eight 100 Hz recordings of the bench): thousandths of a unit of ΔBIC.
NOISE_SHARE_TOLERANCE = 0.02


def cost_tolerance(n_fit: int) -> float:
    """least_squares' ftol (an iteration's gain relative to the cost, ½·RSS ≈ ½·n·σ² near a
    fit) for a gain of NOISE_SHARE_TOLERANCE·σ² in the RSS, and never tighter than 1e-7."""
    return max(1e-7, NOISE_SHARE_TOLERANCE / max(n_fit, 1))


def error_rows(problem: Problem, angle_deg: np.ndarray) -> np.ndarray:
    """−misfit on the fitting samples, the rows an output-error fit takes: a finger driven
    unstable (strong softening, say) is a very bad fit, not a crash."""
    with np.errstate(invalid="ignore"):
        error = -problem.misfit(angle_deg)[problem.fit_mask]
    return np.where(np.isfinite(error), np.clip(error, -DIVERGED_DEG, DIVERGED_DEG), DIVERGED_DEG)


@dataclass(frozen=True)
class PriorRows:
    """The prior on those of a fit's parameters it holds (`held`, their indices), as rows in
    the residual's units: a log-normal about the nominal, w·ln(v/v0)/s."""

    weight_deg: float
    held: list[int]
    centres: np.ndarray
    widths: np.ndarray

    @staticmethod
    def of(prior: Prior, params: Sequence[Param]) -> PriorRows:
        held = [i for i, p in enumerate(params) if p.label in prior.widths]
        return PriorRows(prior.weight_deg, held, np.array([prior.centres[params[i].label] for i in held]),
                         np.array([prior.widths[params[i].label] for i in held]))

    def __call__(self, values: np.ndarray) -> np.ndarray:
        """The rows at every parameter's (physical) `values`."""
        return self.weight_deg * np.log(np.maximum(values[self.held], 1e-300) / self.centres) / self.widths


def fit(problem: Problem, params: Sequence[Param], start: Sequence[float], base: SimFinger | None = None,
        max_nfev: int = 60) -> Fit:
    """Least squares over `params` from `start`, everything else held at `base`; a fit asked
    before on the same recording, misfit and prior is found again (model/fit_cache.py)."""
    params = tuple(params)
    start = [float(v) for v in start]
    key, anchors = fit_key(problem, params, start, base, max_nfev)
    def run() -> Fit:
        return _read_only(_fit(problem, params, start, base, max_nfev))

    return problem.fits.get_or_fit(key, anchors, run,
                                   lambda f: f.angle_deg.nbytes + f.jacobian.nbytes + f.values.nbytes)


def _read_only(f: Fit) -> Fit:
    """A kept fit is shared by every caller that asks it: its arrays are read-only (a copy
    would do too, but moves the arrays' alignment, and with it the last bits of NumPy's
    sums: the results would no longer be those of the fit run again)."""
    for array in (f.values, f.angle_deg, f.jacobian, f.prior_information):
        if array is not None:
            array.flags.writeable = False
    return f


def fit_key(problem: Problem, params: tuple[Param, ...], start: list[float], base: SimFinger | None,
            max_nfev: int) -> tuple[tuple[object, ...], tuple[object, ...]]:
    """What a fit depends on: the key (by value) and the arrays it reads (by identity, the
    cache's anchors). Not the noise model's AR order or coefficients: they score a fit,
    they do not enter it (Problem.misfit takes out the offset and drift only)."""
    key = (np.packbits(problem.fit_mask).tobytes(), problem.fit_mask.size, repr(problem.prior),
           repr(problem.given_effects), problem.input_hold, repr(problem.rate_hz), problem.substeps,
           repr(problem.angle0_deg), repr(problem.chamber0_kpa), problem.released, repr(params),
           tuple(map(repr, start)), finger_key(base or problem.base), max_nfev)
    anchors = (problem.measured_deg, problem.pressure_kpa, problem.missing, problem.noise.basis,
               problem.noise.start)
    return key, anchors


def _fit(problem: Problem, params: tuple[Param, ...], start: Sequence[float], base: SimFinger | None,
         max_nfev: int) -> Fit:
    scales = np.array([p.scale for p in params])
    lower, upper = _scaled_bounds(params)

    def residual(x: np.ndarray) -> np.ndarray:
        return error_rows(problem, problem.simulate(problem.finger(params, x * scales, base)))

    prior_rows = PriorRows.of(problem.prior, params)
    held = prior_rows.held

    def cost_rows(x: np.ndarray) -> np.ndarray:
        return np.concatenate((residual(x), prior_rows(x * scales))) if held else residual(x)

    x0 = _into_bounds(np.asarray(start, dtype=float) / scales, lower, upper)
    result = least_squares(cost_rows, x0, bounds=(lower, upper), method="trf", x_scale="jac",
                           diff_step=1e-6, max_nfev=max_nfev, xtol=1e-7,
                           ftol=cost_tolerance(problem.n_fit), gtol=1e-8,
                           **parallel_columns())
    values = result.x * scales
    finger = problem.finger(params, values, base)
    n = problem.n_fit
    data = result.fun[:n]
    information = None
    prior_cost = 0.0
    if held:
        information = np.zeros(len(params))
        information[held] = (prior_rows.weight_deg / (prior_rows.widths * values[held])) ** 2
        prior_cost = float(result.fun[n:] @ result.fun[n:])
    # the solver returns a point it evaluated: its angle comes from the problem's cache
    return Fit(params, values, finger, problem.simulate(finger), float(data @ data), result.jac[:n] / scales,
               n, information, prior_cost)


def sensitivity(problem: Problem, param: Param, finger: SimFinger, angle_deg: np.ndarray) -> np.ndarray:
    """d angle / d value at `finger` (forward difference inside the bounds), every sample."""
    value = problem.values([param], finger)[0]
    step = 0.05 * param.scale
    if value + step > param.upper:
        step = -step
    moved = problem.simulate(problem.finger([param], [value + step], finger))
    return (moved - angle_deg) / step


FAR_FACTOR = 3.0  # a plain refit this many times off the nominal is checked against the prior


def far_from_nominal(problem: Problem, refit: Fit, factor: float = FAR_FACTOR) -> list[tuple[str, float]]:
    """Plain parameters of the refit more than `factor` times above or below the nominal."""
    nominal = problem.values(refit.params)
    far = []
    for p, value, centre in zip(refit.params, refit.values, nominal, strict=True):
        if not p.is_effect and centre > 0.0 and value > 0.0 and abs(np.log(value / centre)) > np.log(factor):
            far.append((p.label, float(value / centre)))
    return far


def nominal_prior(problem: Problem, params: Sequence[Param], sigma_deg: float) -> Prior:
    """The nominal's uncertainty on the plain parameters among `params`: a log-normal prior
    of PRIOR_RELATIVE_WIDTH about the model's values, weighted by the noise's std."""
    plain = [(p.label, float(v)) for p, v in zip(params, problem.values(params), strict=True)
             if not p.is_effect and v > 0.0]
    return Prior(dict(plain), {label: PRIOR_RELATIVE_WIDTH for label, _ in plain}, sigma_deg)


MAX_RELATIVE_STD = 0.1  # a plain parameter known worse than ±10 % is not identified


def relative_std(f: Fit) -> np.ndarray:
    """Each parameter's standard error over its value."""
    return f.std() / np.maximum(np.abs(f.values), 1e-300)


def unpinned(f: Fit) -> list[str]:
    """The plain parameters (k, B, N) this fit knows worse than MAX_RELATIVE_STD: what the
    recording cannot pin, which the nominal's prior then holds (the plain refit in engine.py,
    a joint fit in search/forward_selection.py)."""
    return [p.label for p, r in zip(f.params, relative_std(f), strict=True)
            if not p.is_effect and not r < MAX_RELATIVE_STD]
