"""The sensor's noise as a lab's recording has it: correlated in time, on an offset that drifts.

An analog chain and its anti-alias filter make the noise of a flex sensor correlated over
tens to hundreds of milliseconds, and the sensor's zero wanders slowly. A statistic that
takes such a residual for white noise lies: the Ljung-Box test fails on the noise alone,
and ΔBIC computed as if every sample were independent is inflated by the correlation.

So the tests run on innovations, as the prediction-error method has it: the residual
with its offset and slow drift projected out (nuisance terms, not physics), then passed
through the autoregressive filter e_t = r_t − Σ a_i·r_{t−i} estimated on the plain
model's residual. Under the right model the innovations are white, and ΔBIC, the held-out
score and the whiteness test computed on them mean what they say.
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass

import numpy as np
from scipy import fft, linalg, signal

from rtcore.config import Effects
from rtcore.sim import SimFinger, simulate

MAX_ORDER = 40  # AR orders tried: enough for a filtered, partly correlated sensor at 1 kHz
DRIFT_PERIOD_S = 20.0  # slower than this is sensor drift (a few terms over a recording)


@dataclass(frozen=True)
class StartMotion:
    """The finger's free motion from an unknown start (start_motion), as a nuisance beside
    an orthonormal drift basis Q: its columns S over the samples where they have not yet
    died out, QᵀS, and (S'ᵀS')⁻¹ for S' = S − Q·QᵀS. With these the projection onto both
    costs what Q's alone does: r − Q·(a − QᵀS·b) − S·b, a = Qᵀr, b = (S'ᵀS')⁻¹·(Sᵀr − (QᵀS)ᵀa).
    (Orthonormalised into Q instead, the columns become dense: a third more time per
    residual at 1 kHz.)"""

    columns: np.ndarray  # K × s: S over its first K samples (0 beyond)
    on_drift: np.ndarray  # m × s: QᵀS
    inverse_gram: np.ndarray  # s × s: (S'ᵀS')⁻¹, by pseudo-inverse

    @staticmethod
    def of(columns: np.ndarray, basis: np.ndarray) -> StartMotion:
        alive = np.abs(columns) > 1e-12 * np.abs(columns).max(axis=0)
        k = int(np.flatnonzero(alive.any(axis=1))[-1]) + 1 if alive.any() else 1
        s = np.ascontiguousarray(columns[:k])
        on_drift = basis[:k].T @ s
        gram = s.T @ s - on_drift.T @ on_drift
        return StartMotion(s, on_drift, np.linalg.pinv(gram, rcond=1e-10, hermitian=True))


@dataclass(frozen=True)
class NoiseModel:
    """The noise's structure: an AR order and the nuisance basis (offset, slow drift).

    The AR coefficients are estimated again on each model's own residual (the prediction
    error method with the noise model fitted jointly): a filter fixed on the plain model's
    residual would be tuned to that model's misfit too, and would hide the very effect a
    richer model explains. The order is chosen once, on the plain model's residual."""

    order: int
    basis: np.ndarray | None  # n × m: offset and slow drift, orthonormal columns
    ar: np.ndarray  # the coefficients on the plain model's residual (reported)
    innovation_std_deg: float
    start: StartMotion | None = None  # the motion of a start not known to be at rest

    def detrend(self, residual: np.ndarray) -> np.ndarray:
        """The residual with its offset and slow drift (and the start's motion) taken out."""
        if self.basis is None:
            return residual
        a = on_basis(self.basis, residual)
        if self.start is None:
            return residual - from_basis(self.basis, a)
        s = self.start
        k = s.columns.shape[0]
        b = s.inverse_gram @ (s.columns.T @ residual[:k] - s.on_drift.T @ a)
        out = residual - from_basis(self.basis, a - s.on_drift @ b)
        out[:k] -= s.columns @ b
        return out

    def whiten(self, residual: np.ndarray, valid: np.ndarray | None = None) -> np.ndarray:
        """Innovations of a residual on every sample, with AR coefficients of this order
        estimated on its `valid` samples (the first `order` carry the filter's start)."""
        r = self.detrend(residual)
        return prewhiten(r, self.order, r if valid is None else r[valid])


def prewhiten(x: np.ndarray, order: int, fit_on: np.ndarray | None = None) -> np.ndarray:
    """x through the AR(order) filter estimated on `fit_on` (default x itself); x as it is
    for order 0."""
    if order == 0:
        return x
    a, _ = yule_walker(x if fit_on is None else fit_on, order)
    return signal.lfilter(np.concatenate(([1.0], -a)), [1.0], x)


def autocovariance(x: np.ndarray, lags: int) -> np.ndarray:
    """γ(0..lags), biased, in O(n·lags)."""
    x = x - x.mean()
    n = x.size
    return np.array([float(x[: n - k] @ x[k:]) / n for k in range(lags + 1)])


def yule_walker(x: np.ndarray, order: int) -> tuple[np.ndarray, float]:
    """AR(order) coefficients and innovation variance by Yule-Walker."""
    gamma = autocovariance(x, order)
    if gamma[0] <= 0.0:
        return np.zeros(order), 0.0
    a = linalg.solve_toeplitz(gamma[:order], gamma[1: order + 1])
    return a, float(max(gamma[0] - a @ gamma[1: order + 1], 0.0))


@functools.lru_cache(maxsize=2)
def drift_basis(n: int, rate_hz: float) -> np.ndarray:
    """Orthonormal columns spanning a constant and the drifts slower than DRIFT_PERIOD_S:
    a cosine series with periods down to about that, at least the constant and a slope.

    The columns are the first of the orthonormal DCT-II basis (cos πk(i + ½)/n are
    orthogonal over the n samples, of squared norm n for k = 0 and n/2 beyond), so that
    on_basis and from_basis can take the DCT's route on a long recording. Kept for the next
    call with the same length and rate (read-only): a diagnosis asks for it three or four times.
    """
    duration_s = n / rate_hz
    terms = max(1, int(2.0 * duration_s / DRIFT_PERIOD_S))
    x = (np.arange(n) + 0.5) / n
    columns = [np.full(n, 1.0 / np.sqrt(n))] + [np.cos(np.pi * k * x) * np.sqrt(2.0 / n)
                                                 for k in range(1, terms + 1)]
    q = np.column_stack(columns)
    q.setflags(write=False)
    return q


# From this many drift columns on, a projection onto them goes by the DCT (O(n log n))
# instead of the basis matrix (O(n·m), memory-bound: a 5-minute, 500 Hz recording has 31
# columns, 37 MB read twice for every simulated angle's misfit, twice the DCT's time)
DCT_MIN_COLUMNS = 16


def on_basis(basis: np.ndarray, x: np.ndarray) -> np.ndarray:
    """basisᵀ·x for a drift_basis."""
    m = basis.shape[1]
    if m < DCT_MIN_COLUMNS:
        return basis.T @ x
    return fft.dct(x, type=2, norm="ortho")[:m]


def from_basis(basis: np.ndarray, a: np.ndarray) -> np.ndarray:
    """basis·a for a drift_basis."""
    m = basis.shape[1]
    if m < DCT_MIN_COLUMNS:
        return basis @ a
    full = np.zeros(basis.shape[0])
    full[:m] = a
    # in place: `full` is this call's own (the same transform, bit for bit, without its copy)
    return fft.idct(full, type=2, norm="ortho", overwrite_x=True)


def start_motion(finger: SimFinger, n: int, rate_hz: float) -> np.ndarray:
    """The plain finger's free motion (no command, no effect) from a unit angle and from a
    unit velocity, every sample (n × 2, deg): what a start not quite at rest adds to the
    angle, dying out over the first decay times. Taken out of every residual as a nuisance,
    it lets those first samples count without trusting the start."""
    plain = SimFinger(dataclasses.replace(finger.prbm, effects=Effects()), supply_min_kpa=0.0,
                      supply_max_kpa=max(finger.supply_max_kpa, 0.0))  # no valve, no object: free
    still = np.zeros(n)
    rate_per_s = np.sqrt(plain.prbm.stiffness_nm_per_rad / plain.prbm.inertia_kgm2)
    moved, _ = simulate(plain, still, rate_hz, 1, 1.0, 0.0, 0.0)
    pushed, _ = simulate(plain, still, rate_hz, 1, 0.0, rate_per_s, 0.0)
    return np.column_stack((moved, pushed))


def choose_order(x: np.ndarray, max_order: int = MAX_ORDER) -> int:
    """The AR order by BIC, 0 for white noise."""
    n = x.size
    gamma = autocovariance(x, max_order)
    if gamma[0] <= 0.0:
        return 0
    best_order, best_bic = 0, n * np.log(gamma[0])
    for p in range(1, max_order + 1):
        a = linalg.solve_toeplitz(gamma[:p], gamma[1: p + 1])
        variance = float(gamma[0] - a @ gamma[1: p + 1])
        if variance <= 0.0:
            break
        bic = n * np.log(variance) + p * np.log(n)
        if bic < best_bic:
            best_order, best_bic = p, bic
    return best_order


def estimate(residual: np.ndarray, valid: np.ndarray, rate_hz: float, with_drift: bool = True,
             start: np.ndarray | None = None) -> NoiseModel:
    """The noise model from the plain model's residual (every sample; `valid` marks those
    that are data): nuisance offset and drift (and the `start` columns) first, then the AR
    order of what is left."""
    nuisance = nuisance_only(residual.size, rate_hz, start) if with_drift else WHITE
    left = nuisance.detrend(residual)[valid]
    order = choose_order(left)
    a, variance = yule_walker(left, order) if order else (np.zeros(0), float(np.var(left)))
    return dataclasses.replace(nuisance, order=order, ar=a, innovation_std_deg=float(np.sqrt(variance)))


def nuisance_only(n: int, rate_hz: float, start: np.ndarray | None = None) -> NoiseModel:
    """Offset and slow drift (and the `start` columns), no AR filter yet (for the plain
    refit, before its residual tells the order)."""
    basis = drift_basis(n, rate_hz)
    return NoiseModel(0, basis, np.zeros(0), 0.0, None if start is None else StartMotion.of(start, basis))


WHITE = NoiseModel(0, None, np.zeros(0), 0.0)

__all__ = ["WHITE", "NoiseModel", "StartMotion", "autocovariance", "choose_order", "drift_basis", "estimate",
           "nuisance_only", "prewhiten", "start_motion", "yule_walker"]
