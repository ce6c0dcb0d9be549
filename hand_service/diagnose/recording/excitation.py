"""What this recording's command holds, in words: where its power lies against the
finger's own resonance, so that the advice for a better recording is about this one.

k, B and N each leave their mark in a different band: N and k in the slow, quasi-static
part (k/N is the static gain), B and k/A near the resonance. A command with nothing near
the resonance cannot separate B from k; one with no slow part cannot pin the static gain.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import signal

QUIET = 0.05  # a band with under 5 % of the command's power is missing
SINGLE_TONE = 0.9  # one spectral peak with over 90 % of the power: one frequency
PURE_SINE = 0.995  # a sine at that frequency explains this share of the variance: a sine


@dataclass(frozen=True)
class Excitation:
    resonance_hz: float
    slow: float  # fraction of the varying power below resonance/4
    near: float  # within resonance/2 .. 2·resonance
    fast: float  # above 2·resonance
    tone_hz: float | None  # the frequency that holds nearly all the power, if one does
    moves: bool
    pure: bool = True  # at tone_hz: a sine (else a triangle, a ramp up and down)

    def describe(self) -> str:
        if not self.moves:
            return "the command barely moves"
        if self.tone_hz is not None and self.pure:
            return f"the command is a single sine at {self.tone_hz:.2g} Hz"
        if self.tone_hz is not None:
            return (f"the command repeats at {self.tone_hz:.2g} Hz with nearly all its power at that one "
                    "frequency (a ramp up and down)")
        return (f"the command's varying power lies {100 * self.slow:.0f} % below "
                f"{self.resonance_hz / 4:.2g} Hz, {100 * self.near:.0f} % near the finger's "
                f"resonance ({self.resonance_hz:.2g} Hz) and {100 * self.fast:.0f} % above")

    def advice(self) -> str:
        """What to add to the next recording."""
        if not self.moves:
            return "drive the finger: steps between levels, or a chirp through its resonance"
        wanted = []
        if self.tone_hz is not None or self.near < QUIET:
            wanted.append(f"content near {self.resonance_hz:.2g} Hz (steps, or a chirp through it)")
        if self.tone_hz is not None or self.slow < QUIET:
            wanted.append("slow or held levels (steps, ramps)")
        if not wanted:
            return "a longer recording, or larger steps: the bands are there but too weak against the noise"
        return "add " + " and ".join(wanted)

    def sentence(self) -> str:
        return f"{self.describe()}: {self.advice()}"


def analyse(command_kpa: np.ndarray, rate_hz: float, stiffness_nm_per_rad: float,
            inertia_kgm2: float) -> Excitation:
    resonance_hz = math.sqrt(stiffness_nm_per_rad / inertia_kgm2) / (2.0 * math.pi)
    u = np.asarray(command_kpa, dtype=float) - float(np.mean(command_kpa))
    if not np.any(np.abs(u) > 1e-9 * max(1.0, float(np.max(np.abs(command_kpa))))):
        return Excitation(resonance_hz, 0.0, 0.0, 0.0, None, False)
    f, power = signal.periodogram(u, fs=rate_hz, detrend=False)
    total = float(power[1:].sum())
    if total <= 0.0:
        return Excitation(resonance_hz, 0.0, 0.0, 0.0, None, False)
    peak = int(np.argmax(power[1:])) + 1
    around_peak = float(power[max(1, peak - 2): peak + 3].sum()) / total
    tone = float(f[peak]) if around_peak > SINGLE_TONE else None
    pure = tone is None or sine_share(u, tone, rate_hz) >= PURE_SINE

    def share(low: float, high: float) -> float:
        return float(power[(f > low) & (f <= high)].sum()) / total

    return Excitation(resonance_hz, share(0.0, resonance_hz / 4), share(resonance_hz / 2, 2 * resonance_hz),
                      share(2 * resonance_hz, math.inf), tone, True, pure)


def sine_share(u: np.ndarray, frequency_hz: float, rate_hz: float) -> float:
    """The share of u's variance a sine at frequency_hz (any phase) explains."""
    t = np.arange(u.size) / rate_hz
    basis = np.column_stack((np.sin(2 * np.pi * frequency_hz * t), np.cos(2 * np.pi * frequency_hz * t)))
    coef, *_ = np.linalg.lstsq(basis, u, rcond=None)
    left = u - basis @ coef
    return 1.0 - float(left @ left) / float(u @ u)


__all__ = ["Excitation", "analyse"]
