"""A lab's flex sensor, as the angle reaches the recording: an offset left after zeroing, a
slow drift, white noise, noise correlated over 0.05–0.2 s (a first-order filtered source:
the analog chain), then the ADC's steps."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import signal


@dataclass(frozen=True)
class Sensor:
    white_deg: float = 0.1
    correlated_deg: float = 0.2
    correlation_s: float = 0.1
    drift_deg: float = 0.2
    drift_period_s: float = 150.0
    offset_deg: float = 0.0
    adc_step_deg: float = 0.05

    @property
    def noise_rms_deg(self) -> float:
        """The RMS of the noise that changes from sample to sample (white, correlated and the
        ADC's rounding): the yardstick of concealment. Offset and drift are not in it."""
        return math.sqrt(self.white_deg**2 + self.correlated_deg**2 + self.adc_step_deg**2 / 12.0)

    @classmethod
    def random(cls, rng: np.random.Generator) -> Sensor:
        return cls(
            white_deg=float(rng.uniform(0.05, 0.2)),
            correlated_deg=float(rng.uniform(0.1, 0.3)),
            correlation_s=float(rng.uniform(0.05, 0.2)),
            drift_deg=float(rng.uniform(0.1, 0.4)),
            drift_period_s=float(rng.uniform(90.0, 240.0)),
            offset_deg=float(rng.uniform(-0.5, 0.5)),
            adc_step_deg=float(rng.choice([0.02, 0.05, 0.1])),
        )

    def correlated(self, rng: np.random.Generator, n: int, rate_hz: float) -> np.ndarray:
        """First-order filtered white noise of std `correlated_deg` and time constant
        `correlation_s`, started in its stationary state: autocorrelation e^(−τ/τc)."""
        if self.correlated_deg <= 0:
            return np.zeros(n)
        a = math.exp(-1.0 / (self.correlation_s * rate_hz))
        drive = rng.normal(0.0, self.correlated_deg * math.sqrt(1.0 - a * a), n)
        zi = np.array([a * rng.normal(0.0, self.correlated_deg)])
        out, _ = signal.lfilter([1.0], [1.0, -a], drive, zi=zi)
        return out

    def additive(self, rng: np.random.Generator, n: int, rate_hz: float) -> np.ndarray:
        """Everything the sensor adds before the ADC (deg)."""
        t = np.arange(n) / rate_hz
        phase = rng.uniform(0.0, 2.0 * math.pi)
        drift = self.drift_deg * (np.sin(2.0 * math.pi * t / self.drift_period_s + phase) - math.sin(phase))
        white = rng.normal(0.0, self.white_deg, n)
        return self.offset_deg + drift + white + self.correlated(rng, n, rate_hz)

    def quantise(self, angle_deg: np.ndarray | float) -> np.ndarray | float:
        q = self.adc_step_deg
        return np.round(np.asarray(angle_deg) / q) * q if q > 0 else angle_deg

    def read(self, true_deg: np.ndarray, additive: np.ndarray) -> np.ndarray:
        return np.asarray(self.quantise(true_deg + additive))
