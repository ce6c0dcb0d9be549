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


RINGS_BELOW_ZETA = 0.7  # a finger rings (has a resonance worth the name) below this damping ratio
SHOWN_BELOW = 0.25  # a frequency this recording's rate can show: below a quarter of it
REPEATS_CORRELATION = 0.5  # the command's autocorrelation at its period, at least
REPEATS_CYCLES = 2.5  # and at least this many periods in the recording


@dataclass(frozen=True)
class Excitation:
    resonance_hz: float  # the finger's own frequency: its resonance, or its corner where it does not ring
    slow: float  # fraction of the varying power below resonance/4
    near: float  # within resonance/2 .. 2·resonance
    fast: float  # above 2·resonance
    tone_hz: float | None  # the frequency that holds nearly all the power, if one does and it repeats
    moves: bool
    pure: bool = True  # at tone_hz: a sine (else a triangle, a ramp up and down)
    rings: bool = True  # the refitted finger is under-damped (ζ < RINGS_BELOW_ZETA)
    shown: bool = True  # the rate can show its own frequency (below SHOWN_BELOW of the rate)

    @property
    def own(self) -> str:
        return "resonance" if self.rings else "corner frequency (k/B: it does not ring)"

    def describe(self) -> str:
        if not self.moves:
            return "the command barely moves"
        if self.tone_hz is not None and self.pure:
            return f"the command is a single sine at {self.tone_hz:.2g} Hz"
        if self.tone_hz is not None:
            return (f"the command repeats at {self.tone_hz:.2g} Hz with nearly all its power at that one "
                    "frequency (a ramp up and down)")
        if not self.shown:
            return (f"the command's varying power lies {100 * self.slow:.0f} % below "
                    f"{self.resonance_hz / 4:.2g} Hz; the finger's own frequency is beyond what this "
                    "sample rate shows")
        return (f"the command's varying power lies {100 * self.slow:.0f} % below "
                f"{self.resonance_hz / 4:.2g} Hz, {100 * self.near:.0f} % near the finger's "
                f"{self.own} ({self.resonance_hz:.2g} Hz) and {100 * self.fast:.0f} % above")

    def advice(self) -> str:
        """What to add to the next recording."""
        if not self.moves:
            return "drive the finger: steps between levels, or a chirp through its own frequency"
        wanted = []
        if self.shown and (self.tone_hz is not None or self.near < QUIET):
            wanted.append(f"content near {self.resonance_hz:.2g} Hz (steps, or a chirp through it)")
        if self.tone_hz is not None or self.slow < QUIET:
            wanted.append("slow or held levels (steps, ramps)")
        if not wanted:
            return "a longer recording, or larger steps: the bands are there but too weak against the noise"
        return "add " + " and ".join(wanted)

    def sentence(self) -> str:
        return f"{self.describe()}: {self.advice()}"


def damping_ratio(stiffness_nm_per_rad: float, damping_nms_per_rad: float, inertia_kgm2: float) -> float:
    return damping_nms_per_rad / (2.0 * math.sqrt(max(stiffness_nm_per_rad, 1e-300) * inertia_kgm2))


def own_frequency_hz(stiffness_nm_per_rad: float, damping_nms_per_rad: float | None,
                     inertia_kgm2: float) -> tuple[float, bool]:
    """The finger's own frequency and whether it rings: its undamped resonance √(k/A)/2π
    where ζ < RINGS_BELOW_ZETA (or the damping is not given), else its slow corner k/(2πB)."""
    k = max(stiffness_nm_per_rad, 0.0)
    if damping_nms_per_rad is None or damping_ratio(k, damping_nms_per_rad, inertia_kgm2) < RINGS_BELOW_ZETA:
        return math.sqrt(k / inertia_kgm2) / (2.0 * math.pi), True
    return k / (2.0 * math.pi * damping_nms_per_rad), False


def period_s(command_kpa: np.ndarray, rate_hz: float) -> float | None:
    """The command's period where it repeats: the first peak of its autocorrelation
    (unbiased) past its first zero crossing that comes near the highest, at least
    REPEATS_CORRELATION, with at least REPEATS_CYCLES periods in the recording; else None."""
    u = np.asarray(command_kpa, dtype=float) - float(np.mean(command_kpa))
    n = u.size
    if n < 8 or float(u @ u) <= 0.0:
        return None
    size = 1 << int(np.ceil(np.log2(2 * n)))
    spectrum = np.fft.rfft(u, size)
    acov = np.fft.irfft(spectrum * np.conj(spectrum), size)[:n]
    longest = int(n / REPEATS_CYCLES)
    if longest < 2:
        return None
    r = acov[: longest + 1] / (n - np.arange(longest + 1)) / (acov[0] / n)
    below = np.flatnonzero(r < 0.0)
    if below.size == 0:
        return None
    after = r[below[0]:]
    best = float(np.max(after))
    if best < REPEATS_CORRELATION:
        return None
    lag = int(below[0] + np.flatnonzero(after >= 0.9 * best)[0])  # the first peak, not a multiple
    while lag + 1 <= longest and r[lag + 1] > r[lag]:
        lag += 1
    return lag / rate_hz


def analyse(command_kpa: np.ndarray, rate_hz: float, stiffness_nm_per_rad: float,
            inertia_kgm2: float, damping_nms_per_rad: float | None = None) -> Excitation:
    own_hz, rings = own_frequency_hz(stiffness_nm_per_rad, damping_nms_per_rad, inertia_kgm2)
    shown = own_hz < SHOWN_BELOW * rate_hz
    u = np.asarray(command_kpa, dtype=float) - float(np.mean(command_kpa))
    if not np.any(np.abs(u) > 1e-9 * max(1.0, float(np.max(np.abs(command_kpa))))):
        return Excitation(own_hz, 0.0, 0.0, 0.0, None, False, rings=rings, shown=shown)
    f, power = signal.periodogram(u, fs=rate_hz, detrend=False)
    total = float(power[1:].sum())
    if total <= 0.0:
        return Excitation(own_hz, 0.0, 0.0, 0.0, None, False, rings=rings, shown=shown)
    peak = int(np.argmax(power[1:])) + 1
    around_peak = float(power[max(1, peak - 2): peak + 3].sum()) / total
    tone = float(f[peak]) if around_peak > SINGLE_TONE else None
    if tone is not None:  # one frequency holds the power, but the command must also repeat at it
        period = period_s(u, rate_hz)
        if period is None or abs(period * tone - 1.0) > 0.25:
            tone = None
    pure = tone is None or sine_share(u, tone, rate_hz) >= PURE_SINE

    def share(low: float, high: float) -> float:
        return float(power[(f > low) & (f <= high)].sum()) / total

    return Excitation(own_hz, share(0.0, own_hz / 4), share(own_hz / 2, 2 * own_hz),
                      share(2 * own_hz, math.inf), tone, True, pure, rings, shown)


def sine_share(u: np.ndarray, frequency_hz: float, rate_hz: float) -> float:
    """The share of u's variance a sine at frequency_hz (any phase) explains."""
    t = np.arange(u.size) / rate_hz
    basis = np.column_stack((np.sin(2 * np.pi * frequency_hz * t), np.cos(2 * np.pi * frequency_hz * t)))
    coef, *_ = np.linalg.lstsq(basis, u, rcond=None)
    left = u - basis @ coef
    return 1.0 - float(left @ left) / float(u @ u)


__all__ = ["Excitation", "analyse", "damping_ratio", "own_frequency_hz", "period_s"]
