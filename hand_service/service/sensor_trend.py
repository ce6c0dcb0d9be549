"""The model check's trend test: a flex sensor drifting away from the model.

The model check (plausibility.py) faults when the innovation (measured angle less
predicted) leaves a bound, and the bound must hold every error the model's parameters may
have, ±29° on a sweep to 100° at 10 %. A sensor that drifts slowly stays inside it for
seconds (at −5°/s: 6 s, the true angle 27° past its target). What tells a drift from a
model that is a little off is time: a parameter error is a function of the state, the
same innovation whenever the finger passes the same angle, pressure and speed again; a
drift grows with time whatever the finger does.

So the innovation e of each finger is fitted, by least squares with exponential
forgetting (time constant TREND_WINDOW_S), as

    e ≈ c0 + c1·(t − now) + a·θ + b·s_k + d·s_B

where θ, s_k and s_B are the prediction and its sensitivities to the stiffness and the
damping (a parameter error, to first order, is such a combination; plausibility.py).
c1 is the innovation's trend in deg/s with what the state explains taken out.

Both sides are low-passed first, by two first-order stages whose corner is
FILTER_CORNER_SHARE of each finger's natural frequency, and no lower than
FILTER_CORNER_MIN_RAD_PER_S (the filter delays a drift by two time constants; a finger that
rings slowly rings within the trend's own band, where no filter can part them). The
prediction is driven by the measured pressure, and the finger's dynamics turn that
sensor's noise into a ringing at the natural frequency that is in θ and, with the opposite
sign, in the innovation. Fitted raw, a·θ with a ≈ −1 cancels the ringing and, on a finger
that moves slowly meanwhile, leaves c1 ≈ −a·θ': a lightly damped finger's move read as a
drift. A linear relation holds
the same between the filtered signals (t delayed, which c0 absorbs), and the ringing is gone
from both. The noise the trend meets is the innovation's at low frequency, which the
filter passes whole: its white-equivalent level stands for it in the standard error, the
larger of the stated one (the flex sensor's, and the pressure sensor's through N/k) and
the innovation's own, measured from its sample-to-sample differences (a sensor noisier
than the profile says); the filtered residual adds what it holds beyond that noise's
filtered share (a misfit of the state's terms, slow, which the filter passes whole too).

It is judged three ways before a fault:
- TREND_SIGMAS standard errors short of itself;
- only where time is apart from the state over the fit: the trend's variance inflation
  under INFLATION_MAX. In a steady ramp θ runs along t, and a drift and a gain error are
  the same line; only the level check can judge there;
- only where the raw innovation, smoothed over LEVEL_WINDOW_S, is further from zero than
  the noise makes it (three of its standard deviations, with safety.model_margin_deg): the
  sensor has left the model by more than its noise, whatever the fit's statistics say.
Beyond safety.sensor_drift_max_deg_per_s, either way, for model_mismatch_ms in a row: a
fault (`implausible`, the finger named). A finger's fit starts again whenever its prediction
does (arming, leaving force mode, a gap in the samples: the restarted prediction moves
the innovation by what the model's error had made of it, a step the old fit would read
as a trend). It takes no sample for TREND_SETTLE_S (a prediction started at rest from a
finger that was not at rest, released from an object, leaves an innovation that dies
away with the model's own dynamics, a trend for a while that no parameter explains), and
is judged once it holds TREND_WARMUP windows of samples after that.

The sums are kept about the present: as time moves on by dt, the time regressor of every
sample before is dt further in the past, a linear map of the sums (no growing t²).
"""

from __future__ import annotations

import math

import numpy as np

TREND_WINDOW_S = 0.5  # the forgetting's time constant
TREND_SETTLE_S = 0.5  # a fit takes no sample this soon after its prediction started again
TREND_WARMUP = 2.0  # windows of samples a fit holds before it is judged
TERMS = 6  # 1, t − now, θ, s_k, s_B, θ'·RATE_S
RATE_S = 0.05  # the angular rate's regressor, scaled to an angle's size
LEVEL_WINDOW_S = 0.1  # the innovation's smoothing, for the level a drift must have reached
INFLATION_MAX = 10.0  # the trend's variance inflation beyond which time and the state are one
TREND_SIGMAS = 3.0  # the trend judged is this many standard errors short of its estimate
RIDGE = 1e-6  # of the weights' sum, on the diagonal: a finger at rest makes θ, s_k, s_B constants
FILTER_CORNER_SHARE = 0.5  # the low-pass's corner, as a share of the finger's natural frequency
FILTER_CORNER_MIN_RAD_PER_S = 10.0  # and never below this: its delay, 2/corner, at most 0.2 s
FILTERED = 5  # θ, s_k, s_B, θ'·RATE_S, e: the signals low-passed before the fit


class SensorTrend:
    """Per finger, the innovation's trend in deg/s with the state's part taken out."""

    def __init__(self, n_fingers: int, period_s: float, limit_deg_per_s: float, persist_samples: int,
                 level_deg: np.ndarray, natural_rad_per_s: np.ndarray, slow_noise_deg: np.ndarray,
                 window_s: float = TREND_WINDOW_S) -> None:
        self.period_s = period_s
        # the low-pass: per finger, its pole and the white-noise gain of two stages
        corner_rad_per_s = np.maximum(FILTER_CORNER_SHARE * np.asarray(natural_rad_per_s, dtype=float),
                                      FILTER_CORNER_MIN_RAD_PER_S)
        self.pole = np.exp(-period_s * corner_rad_per_s)
        b = self.pole
        self._gain = (1 - b)[:, None]  # a stage's step toward the sample, one period on
        self.noise_gain = (1 - b) ** 4 * (1 + b ** 2) / (1 - b ** 2) ** 3  # Σh², h[j] = (1−b)²(j+1)b^j
        self.stages = np.zeros((2, n_fingers, FILTERED))
        self._signals = np.zeros((n_fingers, FILTERED))
        self.fresh = np.ones(n_fingers, dtype=bool)  # the low-pass starts from the next sample
        self.slow_noise_var = np.asarray(slow_noise_deg, dtype=float) ** 2  # stated
        self._last_deg = np.zeros(n_fingers)  # the raw innovation before, for its differences
        self.difference_square = np.zeros(n_fingers)  # Σ w·Δe²/2: the white noise's variance, weighted
        self.difference_weight = np.zeros(n_fingers)
        self.level_deg = np.asarray(level_deg, dtype=float)
        self.level_forget = math.exp(-period_s / LEVEL_WINDOW_S)
        self.smoothed_deg = np.zeros(n_fingers)  # the innovation, exponentially smoothed
        self.limit_deg_per_s = limit_deg_per_s
        self.persist_samples = persist_samples
        self.forget = math.exp(-period_s / window_s)
        self.settle_samples = math.ceil(TREND_SETTLE_S / period_s)
        self.warmup_samples = self.settle_samples + math.ceil(TREND_WARMUP * window_s / period_s)
        self.sums = np.zeros((n_fingers, TERMS, TERMS))  # Σ w·x·xᵀ
        self.cross = np.zeros((n_fingers, TERMS))  # Σ w·x·e
        self.square = np.zeros(n_fingers)  # Σ w·e²
        self.weight2 = np.zeros(n_fingers)  # Σ w²
        self.forget2 = self.forget ** 2
        self.samples = np.zeros(n_fingers, dtype=np.int64)  # since the fit started
        self.run = np.zeros(n_fingers, dtype=np.int64)  # samples in a row beyond the limit
        self.trend_deg_per_s = np.zeros(n_fingers)
        self.trend_error_deg_per_s = np.zeros(n_fingers)
        self.inflation = np.zeros(n_fingers)
        self.worst_deg_per_s = np.zeros(n_fingers)  # the largest |trend| judged, for the statistics
        self.worst_judged_deg_per_s = np.full(n_fingers, -np.inf)  # of |trend| less its doubt
        self._x = np.zeros((n_fingers, TERMS))
        self._x[:, 0] = 1.0
        self._eye = np.eye(TERMS)

    def restart(self, fingers: np.ndarray) -> None:
        """These fingers' fits start again (their prediction did, on arming or out of force
        mode: what the finger did before is another story)."""
        self.sums[fingers] = 0.0
        self.cross[fingers] = 0.0
        self.square[fingers] = 0.0
        self.weight2[fingers] = 0.0
        self.smoothed_deg[fingers] = 0.0
        self.samples[fingers] = 0
        self.fresh[fingers] = True
        self.difference_square[fingers] = 0.0
        self.difference_weight[fingers] = 0.0
        self.run[fingers] = 0
        self.trend_deg_per_s[fingers] = 0.0

    def skip(self, steps: int) -> None:
        """`steps` sample periods pass: the past moves that much further back and is forgotten
        by as much (x_time -> x_time − dt·x_const, a linear map of the sums)."""
        dt = steps * self.period_s
        sums, cross = self.sums, self.cross
        sums[:, 1, :] -= dt * sums[:, 0, :]
        sums[:, :, 1] -= dt * sums[:, :, 0]
        cross[:, 1] -= dt * cross[:, 0]
        forget = self.forget ** steps
        sums *= forget
        cross *= forget
        self.square *= forget
        self.difference_square *= forget
        self.difference_weight *= forget
        self.weight2 *= self.forget2 ** steps

    def sample(self, steps: int, innovation_deg: np.ndarray, sensitive_rad: np.ndarray,
               rate_rad_s: np.ndarray, checked: np.ndarray) -> int | None:
        """A new sample, `steps` periods after the last: the innovation (deg) of every finger
        and its prediction θ, s_k, s_B (rad). Only `checked` fingers count. The finger whose
        trend stayed beyond the limit for persist_samples, or None."""
        self.skip(steps)
        sums, cross = self.sums, self.cross
        x = self._x
        differenced = checked & ~self.fresh
        step_deg = innovation_deg - self._last_deg
        self.difference_square += np.where(differenced, 0.5 * step_deg * step_deg, 0.0)
        self.difference_weight += differenced
        self._last_deg[:] = innovation_deg
        filtered_deg = self._low_pass(steps, innovation_deg, sensitive_rad, rate_rad_s)
        x[:, 2:] = self.stages[1, :, :4]
        self.samples += checked
        weight = (checked & (self.samples > self.settle_samples)).astype(float)
        sums += weight[:, None, None] * x[:, :, None] * x[:, None, :]
        cross += weight[:, None] * x * filtered_deg[:, None]
        self.square += weight * filtered_deg ** 2
        self.weight2 += weight
        blend = self.level_forget ** steps
        self.smoothed_deg = np.where(checked, blend * self.smoothed_deg + (1 - blend) * innovation_deg,
                                     self.smoothed_deg)
        judged = checked & (self.samples >= self.warmup_samples)
        if not judged.any():
            self.run[:] = 0
            return None
        ridge = RIDGE * (sums[:, 0, 0] + 1.0)
        inverse = np.linalg.inv(sums + ridge[:, None, None] * self._eye)
        coef = (inverse @ cross[:, :, None])[:, :, 0]
        trend = np.where(judged, coef[:, 1], 0.0)
        self.trend_deg_per_s = trend
        np.maximum(self.worst_deg_per_s, np.abs(trend), out=self.worst_deg_per_s)
        self.trend_error_deg_per_s = self._standard_error(coef, inverse)
        doubt = TREND_SIGMAS * self.trend_error_deg_per_s
        judged_deg_per_s = np.where(judged, np.abs(trend) - doubt, -np.inf)
        np.maximum(self.worst_judged_deg_per_s, judged_deg_per_s, out=self.worst_judged_deg_per_s)
        centred = sums[:, 1, 1] - sums[:, 0, 1] ** 2 / np.maximum(sums[:, 0, 0], 1e-12)  # Σw(t − t̄)²
        self.inflation = inverse[:, 1, 1] * centred  # 1: t is apart from the state; ∞: t is the state
        beyond = ((judged_deg_per_s > self.limit_deg_per_s) & (np.abs(self.smoothed_deg) > self.level_deg)
                  & (self.inflation < INFLATION_MAX))
        self.run = np.where(beyond, self.run + steps, 0)
        if not (self.run >= self.persist_samples).any():
            return None
        return int(np.argmax(self.run))

    def _low_pass(self, steps: int, innovation_deg: np.ndarray, sensitive_rad: np.ndarray,
                  rate_rad_s: np.ndarray) -> np.ndarray:
        """Both stages moved on by `steps` periods toward the new sample (a fresh finger's
        start at it); the filtered innovation."""
        signals = self._signals
        signals[:, :3] = sensitive_rad
        signals[:, 3] = rate_rad_s * RATE_S
        signals[:, 4] = innovation_deg
        stages = self.stages
        if self.fresh.any():
            stages[:, self.fresh] = signals[self.fresh]
            self.fresh[:] = False
        gain = self._gain if steps == 1 else (1 - self.pole ** steps)[:, None]
        stages[0] += gain * (signals - stages[0])
        stages[1] += gain * (stages[0] - stages[1])
        return stages[1, :, 4]

    def _standard_error(self, coef: np.ndarray, inverse: np.ndarray) -> np.ndarray:
        """The trend's standard error (deg/s): the residual's weighted variance through the
        fit's covariance, c·s²·(XᵀWX)⁻¹ with c = Σw²/Σw (exact for weights W² = c·W, close for
        exponential forgetting). Large where the finger's own motion runs along time (a ramp:
        θ and t are one regressor then) and the noise can pass for either."""
        weight = np.maximum(self.sums[:, 0, 0], 1e-12)
        weight2 = np.maximum(self.weight2, 1e-12)
        residual = np.maximum(self.square - np.einsum("ij,ij->i", coef, self.cross), 0.0) / weight
        effective = weight ** 2 / weight2  # samples, as many as the weights are worth
        unbiased = residual * effective / np.maximum(effective - TERMS, 1.0)
        measured = self.difference_square / np.maximum(self.difference_weight, 1e-12)
        noise_var = np.maximum(self.slow_noise_var, measured)
        unbiased = noise_var + np.maximum(unbiased - self.noise_gain * noise_var, 0.0)
        variance = unbiased * (weight2 / weight) * inverse[:, 1, 1]
        return np.sqrt(np.maximum(variance, 0.0))
