"""Can the raw angle tell two models apart? A test on the difference of their squared raw errors.

Two models A and B, each simulated from the recorded command alone and scored against the
raw angle with a constant offset of its own (raw_error.py), leave errors a_t and b_t. Their
loss difference d_t = b_t² − a_t² has mean zero where both follow the recording equally well
(Diebold and Mariano 1995). The mean d̄ over n samples has variance Ω/n, Ω the long-run
variance of d, not its variance γ₀: the misfit of a model slightly wrong is slow (a gain off
on a slow command, a shape off on a sine), so successive d_t are far from independent, and
γ₀/n makes a difference of a few slow swings look certain.

Write a = w + s_A, b = w + s_B, w the sensor's noise (common to both) and s each model's own
misfit: d = δ·(2w + s_A + s_B), δ = b − a = s_B − s_A. The noise enters d only through a white
cross term, which dilutes its lag-one correlation; the persistence of what is not white in d
is that of δ and of d itself. A plug-in bandwidth from d's lag-one correlation alone (an AR(1)
for d, as Andrews 1991 gives it) misses it: on two equally accurate models whose misfits
swing slowly, a Newey-West variance with that bandwidth called them apart most of the time.

So Ω is estimated by batch means. τ, the integrated autocorrelation time of δ and of d (the
larger; each 1 + 2 Σ r_k, summed to the first lag where the correlation r_k is no longer
positive), sets the block: BLOCK_TIMES·τ contiguous samples. The correlation of adjacent
blocks' means is then about τ/(4·block) (an AR(1)'s: 1/16), so the B block means are nearly
independent, and t = d̄ / (s_B/√B), s_B their spread, is Student's t with B − 1 degrees of
freedom where the two are equally accurate. B is worse than A on the raw angle beyond what
the recording's own fluctuation can do where t exceeds t's one-sided quantile at LEVEL, and
better where it falls below its negative. A recording shorter than two blocks cannot tell
them apart at all.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.stats import t as student_t

# One-sided level: the chance that a model as accurate as the other is judged worse.
LEVEL = 0.05
# A block's length in integrated autocorrelation times (module doc).
BLOCK_TIMES = 4.0


@dataclass(frozen=True)
class LossDifference:
    """B's squared raw error less A's (deg²): its mean, the mean's standard error from the
    means of `blocks` blocks of `block_samples` samples each, so many samples in all."""

    mean_deg2: float
    stderr_deg2: float
    block_samples: int
    blocks: int
    n: int

    @property
    def statistic(self) -> float:
        """t: positive where B follows the raw angle worse."""
        if self.blocks < 2:
            return 0.0
        if self.stderr_deg2 > 0.0:
            return self.mean_deg2 / self.stderr_deg2
        return 0.0 if self.mean_deg2 == 0.0 else float(np.sign(self.mean_deg2) * np.inf)

    @property
    def critical(self) -> float:
        """Student's t one-sided quantile at LEVEL with blocks − 1 degrees of freedom (inf
        where the recording holds fewer than two blocks)."""
        return float(student_t.ppf(1.0 - LEVEL, self.blocks - 1)) if self.blocks >= 2 else float("inf")

    @property
    def b_worse(self) -> bool:
        """B follows the raw angle worse than A, beyond the recording's fluctuation."""
        return self.statistic > self.critical

    @property
    def b_better(self) -> bool:
        return self.statistic < -self.critical

    @property
    def apart(self) -> bool:
        return self.b_worse or self.b_better


def correlation_time(x: np.ndarray) -> float:
    """The integrated autocorrelation time of x (samples): 1 + 2 Σ r_k over the lags before
    its autocorrelation r_k first stops being positive."""
    n = x.size
    y = x - x.mean()
    var = float(y @ y)
    if n < 2 or var == 0.0:
        return 1.0
    size = 1 << int(np.ceil(np.log2(2 * n)))
    spectrum = np.fft.rfft(y, size)
    r = np.fft.irfft(spectrum * np.conj(spectrum), size)[1:n] / var
    stop = np.flatnonzero(r <= 0.0)
    positive = r[: stop[0]] if stop.size else r
    return float(1.0 + 2.0 * positive.sum())


def loss_difference(a_err_deg: np.ndarray, b_err_deg: np.ndarray) -> LossDifference:
    """The test's figures for two error series over the same samples, in time order."""
    a = np.asarray(a_err_deg, dtype=float)
    b = np.asarray(b_err_deg, dtype=float)
    d = b * b - a * a
    n = d.size
    if n == 0:
        return LossDifference(0.0, 0.0, 0, 0, 0)
    tau = max(correlation_time(b - a), correlation_time(d))
    block = int(min(np.ceil(BLOCK_TIMES * tau), n))
    blocks = n // block
    if blocks < 2:
        return LossDifference(float(d.mean()), float("inf"), block, blocks, n)
    means = d[: blocks * block].reshape(blocks, block).mean(axis=1)
    return LossDifference(float(means.mean()), float(means.std(ddof=1) / np.sqrt(blocks)), block, blocks, n)
