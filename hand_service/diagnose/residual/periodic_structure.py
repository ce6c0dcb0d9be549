"""What repeats with a repeating command: structure the noise model may have taken.

Under a command that repeats (a loop tracking a cosine, a slow sine), the finger's response
repeats too, and so does whatever the model misses of it; the sensor's noise does not. So
the model's misfit (the sensor's offset and slow drift out), cut into the command's periods
and averaged over them, holds the structure left plus the noise shrunk by the number of
periods, and its spread about that average is the noise alone, whatever its correlation
within a period. This is a measure of the noise that needs no stretch at rest
(residual/noise_bound.py needs held commands, which a loop tracking a cosine never has).

A hysteresis loop under a loop tracking a cosine, named asymmetric_stiffness, is the case
that showed the need: its innovations passed as white and its grade was `complete`, while
what repeated stood above the noise between periods (docs/results.md §12.22 has the
figures). A named model is graded `complete` only where what repeats stands under
STRUCTURE_SHARE of the noise.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hand_service.diagnose.recording.excitation import period_s

MIN_PERIODS = 4  # fewer, and the average over periods still carries much of the noise
# What repeats, its noise share taken off, above this share of the noise between periods is
# structure: its estimate's spread is about the noise over √periods
STRUCTURE_SHARE = 0.5


@dataclass(frozen=True)
class Periodic:
    period_s: float
    periods: int
    noise_deg: float  # the misfit's spread about its average over the periods (RMS)
    structure_deg: float  # the average's RMS, the noise's share taken off

    @property
    def exceeded(self) -> bool:
        return self.structure_deg > STRUCTURE_SHARE * self.noise_deg

    def sentence(self) -> str:
        return (f"the residual repeats with the command (every {self.period_s:.3g} s): averaged over its "
                f"{self.periods} periods it stands at {self.structure_deg:.3g} deg RMS against the noise's "
                f"{self.noise_deg:.3g} between periods, structure the noise model takes for correlated noise")


def periodic(misfit_deg: np.ndarray, valid: np.ndarray, pressure_kpa: np.ndarray,
             rate_hz: float) -> Periodic | None:
    """The misfit's part that repeats with the command, against its noise between periods;
    None where the command does not repeat, or repeats fewer than MIN_PERIODS times over
    the valid samples."""
    period = period_s(pressure_kpa, rate_hz)
    index = np.flatnonzero(valid)
    if period is None or index.size == 0:
        return None
    length = period * rate_hz
    samples = round(length)
    first = int(index[0])
    periods = int((index[-1] + 1 - first - samples) // length) + 1 if index[-1] + 1 - first >= samples else 0
    if periods < MIN_PERIODS or samples < 2:
        return None
    starts = [first + round(k * length) for k in range(periods)]
    cut = np.array([misfit_deg[s: s + samples] for s in starts])
    kept = np.array([valid[s: s + samples] for s in starts]).all(axis=0)
    if kept.sum() < 2:
        return None
    cut = cut[:, kept]
    mean = cut.mean(axis=0)
    noise2 = float(np.mean((cut - mean) ** 2)) * periods / (periods - 1)
    structure2 = float(np.mean(mean**2)) - noise2 / periods
    return Periodic(period, periods, float(np.sqrt(noise2)), float(np.sqrt(max(structure2, 0.0))))
