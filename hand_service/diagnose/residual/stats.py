"""The classical residual tests and the time windows where a model misses.

- Whiteness: the Ljung-Box portmanteau statistic on the residual's autocorrelation.
- Cross-correlation of the residual with the past input, against the 99 % band that a
  white residual would stay inside.
- The information criterion (BIC) and a held-out score for one model against another.
- Windows: spans where the residual's local mean square stands clear of the noise.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from hand_service.diagnose.residual.noise import choose_order, prewhiten

Z99 = 2.576  # two-sided 99 % normal quantile


@dataclass
class Whiteness:
    q: float  # Ljung-Box statistic
    lags: int
    p_value: float
    max_autocorr: float  # largest |ρ(τ)| over the lags
    band: float  # 99 % band of a white residual

    @property
    def white(self) -> bool:
        return self.p_value > 1e-3


def autocorrelation(x: np.ndarray, lags: int) -> np.ndarray:
    """ρ(1..lags) of a series, biased estimator (the Ljung-Box convention)."""
    x = x - x.mean()
    denom = float(x @ x)
    if denom <= 0.0:
        return np.zeros(lags)
    return np.array([float(x[:-k] @ x[k:]) / denom for k in range(1, lags + 1)])


def ljung_box(residual: np.ndarray, lags: int) -> Whiteness:
    n = residual.size
    rho = autocorrelation(residual, lags)
    q = float(n * (n + 2) * np.sum(rho**2 / (n - np.arange(1, lags + 1))))
    return Whiteness(q, lags, float(stats.chi2.sf(q, lags)), float(np.max(np.abs(rho))), Z99 / np.sqrt(n))


def whiteness_lags(rate_hz: float) -> int:
    """0.25 s of lags (two to three cycles of the fingers' ringing), at least 20."""
    return max(20, round(0.25 * rate_hz))


@dataclass
class CrossCorrelation:
    lags_s: np.ndarray
    rho: np.ndarray  # ρ_ru(τ): residual now against the input τ earlier
    band: float

    @property
    def worst(self) -> tuple[float, float]:
        k = int(np.argmax(np.abs(self.rho)))
        return float(self.lags_s[k]), float(self.rho[k])

    @property
    def outside(self) -> bool:
        return bool(np.max(np.abs(self.rho)) > self.band)


def cross_correlation(residual: np.ndarray, signal: np.ndarray, lags: int,
                      rate_hz: float) -> CrossCorrelation:
    """ρ_ru(τ) for τ = 0..lags samples (the input leads). Under a white residual each value
    is about normal with variance 1/n, whatever the input's own correlation."""
    r = residual - residual.mean()
    u = signal - signal.mean()
    n = r.size
    scale = float(np.sqrt((r @ r) * (u @ u)))
    if scale <= 0.0:
        rho = np.zeros(lags + 1)
    else:
        rho = np.array([float(r[k:] @ u[: n - k]) / scale for k in range(lags + 1)])
    return CrossCorrelation(np.arange(lags + 1) / rate_hz, rho, Z99 / np.sqrt(n))


def input_independence(innovations: np.ndarray, signal: np.ndarray, lags: int,
                       first_lag: int = 0) -> Whiteness:
    """Do the innovations follow the past input? The input is prewhitened by its own AR
    filter, so that under a right model (innovations white and independent of the input)
    each cross-correlation ρ(τ), τ = first_lag..lags, is about N(0, 1/n) on its own and
    Q = n·Σρ² is χ² with as many degrees of freedom as lags. A model that leaves out how
    the output answers the input (an object in the way, a missing effect) fails it even
    when an AR noise filter has made its innovations look white.

    `first_lag` 1 for a command held from its sample on (zero-order hold): that command
    cannot move the angle sampled at the same instant, so a correlation at lag 0 is the
    other way round, a controller answering the sensor's noise in a closed-loop recording
    (a PI loop on the angle leaves z ≈ −15 there on a right model), and is no evidence
    against the model."""
    u = signal - signal.mean()
    order = choose_order(u)
    u, e = prewhiten(u, order)[order:], innovations[order:]  # past the filter's start
    rho = cross_correlation(e, u, lags, 1.0).rho[first_lag:]
    n = e.size
    q = float(n * np.sum(rho**2))
    return Whiteness(q, rho.size, float(stats.chi2.sf(q, rho.size)), float(np.max(np.abs(rho))),
                     Z99 / np.sqrt(n))


def delta_bic(rss_small: float, rss_large: float, n: int, extra_params: int = 1) -> float:
    """BIC(small) − BIC(large) for Gaussian output error: positive favours the larger model."""
    return float(n * np.log(rss_small / rss_large) - extra_params * np.log(n))


def heldout_z(measured: np.ndarray, before: np.ndarray, after: np.ndarray, sigma: float) -> float:
    """How many standard errors the held-out squared error drops from `before` to `after`.

    If `after` only fitted noise, SSE_before − SSE_after = Σ(2eδ − δ²) with e the noise and
    δ = after − before, whose standard deviation is 2σ·‖δ‖: so z ≈ ‖δ‖/(2σ) when the change
    is real and z ≈ N(0, 1) or less when it is not."""
    delta = after - before
    norm = float(np.sqrt(delta @ delta))
    if norm <= 0.0:
        return 0.0
    gain = float(np.sum((measured - before) ** 2) - np.sum((measured - after) ** 2))
    return gain / (2.0 * sigma * norm)


def heldout_z_innovations(before: np.ndarray, after: np.ndarray, sigma: float) -> float:
    """heldout_z on innovations: `before` and `after` are the two models' innovations on the
    held-out samples (a linear filter of measured − simulated), `sigma` the innovations' std."""
    delta = before - after
    norm = float(np.sqrt(delta @ delta))
    if norm <= 0.0:
        return 0.0
    return float(before @ before - after @ after) / (2.0 * sigma * norm)


def rmse(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(x**2))) if x.size else float("nan")


def windows(residual: np.ndarray, valid: np.ndarray, t_s: np.ndarray, sigma: float, rate_hz: float,
            max_windows: int = 8) -> list[tuple[float, float, float]]:
    """Spans where the residual's local mean square (over 0.5 s) exceeds the noise's by
    more than four standard errors: (t_start, t_end, excess energy in deg²·s), largest
    excess first."""
    width = max(20, round(0.5 * rate_hz))
    squares = np.where(valid, residual**2, 0.0)
    counts = np.convolve(valid.astype(float), np.ones(width), mode="same")
    local = np.convolve(squares, np.ones(width), mode="same") / np.maximum(counts, 1.0)
    threshold = sigma**2 * (1.0 + 4.0 * np.sqrt(2.0 / width))
    above = (local > threshold) & valid & (counts >= width / 2)
    found = []
    edges = np.flatnonzero(np.diff(np.concatenate(([0], above.astype(int), [0]))))
    for start, stop in zip(edges[::2], edges[1::2], strict=True):
        if stop - start < width // 2:
            continue
        excess = float(np.sum(local[start:stop] - sigma**2) / rate_hz)
        found.append((float(t_s[start]), float(t_s[stop - 1]), excess))
    found.sort(key=lambda w: -w[2])
    return found[:max_windows]
