"""The readable reference's filters (rtcore/reference.py): the sensor's Butterworth sections
and the first-order smoothing, as csrc/rtcore_filter.c computes them."""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass
class Biquad:
    """One second-order section, direct form II transposed, a0 = 1."""

    b0: float
    b1: float
    b2: float
    a1: float
    a2: float
    z1: float = 0.0
    z2: float = 0.0

    @classmethod
    def lowpass(cls, tan_half: float, q: float) -> Biquad:
        k2 = tan_half * tan_half
        a0 = 1.0 + tan_half / q + k2
        return cls(k2 / a0, 2.0 * k2 / a0, k2 / a0, 2.0 * (k2 - 1.0) / a0,
                   (1.0 - tan_half / q + k2) / a0)

    @property
    def dc_gain(self) -> float:
        return (self.b0 + self.b1 + self.b2) / (1.0 + self.a1 + self.a2)

    def prime(self, x: float) -> None:
        y = self.dc_gain * x
        self.z2 = self.b2 * x - self.a2 * y
        self.z1 = self.b1 * x - self.a1 * y + self.z2

    def run(self, x: float) -> float:
        y = self.b0 * x + self.z1
        self.z1 = self.b1 * x - self.a1 * y + self.z2
        self.z2 = self.b2 * x - self.a2 * y
        return y


def butter_sections(order: int, cutoff_hz: float, sample_rate_hz: float) -> list[Biquad]:
    """Butterworth low-pass by the bilinear transform with the cutoff prewarped."""
    tan_half = math.tan(math.pi * cutoff_hz / sample_rate_hz)
    return [
        Biquad.lowpass(tan_half, 1.0 / (2.0 * math.sin(math.pi * float(2 * k + 1) / float(2 * order))))
        for k in range(order // 2)
    ]


def first_order_alpha(cutoff_hz: float, dt_s: float) -> float:
    return math.exp(-2.0 * math.pi * cutoff_hz * dt_s)
