"""What the correlated-noise model may take: the sensor's noise measured where the finger is
at rest, against the structure the model leaves while it moves.

The AR noise model (residual/noise.py) is fitted on the plain model's residual. Where physics
outside the library leaves structure that is smooth in time (an end stop, a hysteresis loop),
an AR filter of high enough order predicts it from its own past, and the innovations come out
white: the physics is taken for correlated sensor noise, and the recording is called
`consistent`. The noise the sensor has, though, is there where the finger is still too: where
the command has been held long enough for the refitted finger to settle, the angle moves by
the noise alone (a static error of the model is a constant there, taken out stretch by
stretch). So the noise's size is measured on those stretches, and a residual whose spread,
over the whole recording with the sensor's offset and slow drift taken out, stands clear of
it is input-driven structure, not noise, whatever the AR filter makes of it.

The same stretches bound the AR filter itself. Its order is chosen on the plain model's
residual, and each model's residual gets its own coefficients of that order: on a residual
that is mostly input-driven structure (three effects missing on steps, the misfit seven
times the noise at rest), BIC picks an order of 6 to 8 that predicts the structure from its
own past, the innovations come out near the sensor's noise, and the effects after the first
gain little. Where the plain model's misfit stands clear of the noise at rest
(STRUCTURE_FACTOR), the order is chosen on the stretches at rest instead, where the residual
is the sensor's noise alone: the filter then has the noise's correlation, not the structure's.

The noise's size is its spread about a straight line on each stretch, not about the
stretch's mean: slow physics the model leaves out (creep under a held pressure, a settling
slower than the model's) still moves the angle after the model's finger has settled, and
about the mean that movement counts as noise. Two recordings of a creeping finger named with
dry friction measured its noise at rest at 1.25 and 1.39 times the sensor's, enough to grade
the stand-in `complete` (docs/results.md §12.36). About a line it measures the sensor's.
The AR filter's order (bounded_order) is still chosen on the stretches less their means.

A recording with no such stretches (a chirp, a noise input throughout) gives no bound: the
verdict then rests on the innovations alone, as before.
"""

from __future__ import annotations

import dataclasses
import itertools
from dataclasses import dataclass

import numpy as np

from hand_service.diagnose.residual import noise
from rtcore.sim import SimFinger

SETTLE_DECAYS = 4.0  # the finger is at rest this many of its slowest decay times after a change
MIN_SETTLE_S = 0.2
MIN_STRETCH_S = 1.0  # a stretch at rest shorter than this says little of correlated noise
MIN_REST_S = 2.0  # in all
# A misfit this many times the noise at rest is structure. The noise's correlated part is
# underestimated on a stretch of MIN_STRETCH_S (its mean over the stretch is taken out with
# the model's static error), by up to a fifth of its std for a correlation time of 0.2 s:
# a clean recording stays well under 2; structure three times the noise stands over 3.
STRUCTURE_FACTOR = 2.0
# A named model is graded `complete` only where its misfit stands under this many times the
# noise at rest: over it, structure about the noise's size remains (√(1.5² − 1) = 1.1), which
# `complete` denies. A wrong `complete` costs only the grade, a wrong `unexplained` the
# verdict, hence the lower factor. Clean recordings of the independent truth stand at 0.99–1.04.
GRADE_FACTOR = 1.5


@dataclass(frozen=True)
class NoiseBound:
    rest_std_deg: float  # the noise's std where the finger is at rest
    misfit_std_deg: float  # the plain model's misfit (offset and slow drift out), every scored sample
    rest_s: float  # how much of the recording is at rest

    @property
    def ratio(self) -> float:
        return self.misfit_std_deg / self.rest_std_deg

    @property
    def exceeded(self) -> bool:
        return self.ratio > STRUCTURE_FACTOR

    @property
    def exceeds_grade(self) -> bool:
        return self.ratio > GRADE_FACTOR

    def to_json(self) -> dict:
        return {"rest_noise_std_deg": self.rest_std_deg, "misfit_std_deg": self.misfit_std_deg,
                "rest_s": self.rest_s}

    def grade_sentence(self) -> str:
        return (f"the model's misfit with the named effects ({self.misfit_std_deg:.3g} deg RMS, the sensor's "
                f"offset and slow drift taken out) is {self.ratio:.2g} times the sensor's noise where the "
                f"finger is at rest ({self.rest_std_deg:.3g} deg over {self.rest_s:.3g} s with the command "
                "held): structure the noise model takes for correlated noise remains")

    def sentence(self) -> str:
        return (f"the refitted model's misfit ({self.misfit_std_deg:.3g} deg RMS, the sensor's offset and "
                f"slow drift taken out) is {self.ratio:.2g} times the "
                f"sensor's noise where the finger is at rest ({self.rest_std_deg:.3g} deg over "
                f"{self.rest_s:.3g} s with the command held): the noise model would take input-driven "
                "structure for correlated noise, so the recording is not called consistent")


def slowest_decay_s(finger: SimFinger) -> float:
    """The slowest decay time of the finger's linear part, A·s² + B·s + k (s)."""
    prbm = finger.prbm
    poles = np.roots([prbm.inertia_kgm2, prbm.damping_nms_per_rad, prbm.stiffness_nm_per_rad])
    rate_per_s = float(np.min(-poles.real))
    return 1.0 / rate_per_s if rate_per_s > 0.0 else float("inf")


def rest_stretches(pressure_kpa: np.ndarray, rate_hz: float, settle_s: float) -> list[slice]:
    """The stretches where the command has been held for `settle_s` and stays held at least
    MIN_STRETCH_S more."""
    changed = np.flatnonzero(np.diff(pressure_kpa) != 0.0) + 1
    edges = np.concatenate(([0], changed, [pressure_kpa.size]))
    settle, shortest = int(np.ceil(settle_s * rate_hz)), int(np.ceil(MIN_STRETCH_S * rate_hz))
    out = []
    for start, stop in itertools.pairwise(edges):
        first = start + (settle if start > 0 else 0)  # the recording's start is taken at rest
        if stop - first >= shortest:
            out.append(slice(int(first), int(stop)))
    return out


def bounded_order(model: noise.NoiseModel, residual_deg: np.ndarray, misfit_deg: np.ndarray,
                  scored: np.ndarray, pressure_kpa: np.ndarray, rate_hz: float,
                  finger: SimFinger) -> noise.NoiseModel:
    """`model` (estimated on the plain model's residual) with its AR order and coefficients
    from the stretches at rest, where the misfit (`misfit_deg`: offset and slow drift out)
    stands more than STRUCTURE_FACTOR times above the noise there; else `model`."""
    rest = rest_noise(residual_deg, scored, pressure_kpa, rate_hz, finger)
    if rest is None:
        return model
    rest_std = float(np.sqrt(np.mean(rest * rest)))
    if not misfit_std(misfit_deg, scored) > STRUCTURE_FACTOR * rest_std:
        return model
    order = noise.choose_order(rest)
    a, variance = noise.yule_walker(rest, order) if order else (np.zeros(0), float(np.var(rest)))
    return dataclasses.replace(model, order=order, ar=a, innovation_std_deg=float(np.sqrt(variance)))


def rest_noise(residual_deg: np.ndarray, scored: np.ndarray, pressure_kpa: np.ndarray, rate_hz: float,
               finger: SimFinger, about_line: bool = False) -> np.ndarray | None:
    """The residual on the stretches at rest, each less its mean (`about_line`: less its
    least-squares line), joined; None where the recording has too little at rest."""
    settle_s = max(MIN_SETTLE_S, SETTLE_DECAYS * slowest_decay_s(finger))
    if not np.isfinite(settle_s):
        return None
    parts = []
    for s in rest_stretches(pressure_kpa, rate_hz, settle_s):
        r = residual_deg[s][scored[s]]
        if r.size >= 3 and about_line:
            x = np.flatnonzero(scored[s]).astype(float)
            parts.append(r - np.polyval(np.polyfit(x, r, 1), x))
        elif r.size >= 2:
            parts.append(r - r.mean())
    rest = np.concatenate(parts) if parts else np.zeros(0)
    return rest if rest.size >= MIN_REST_S * rate_hz else None


def bound(residual_deg: np.ndarray, misfit_deg: np.ndarray, scored: np.ndarray, pressure_kpa: np.ndarray,
          rate_hz: float, finger: SimFinger) -> NoiseBound | None:
    """The noise at rest against the misfit: `residual_deg` the plain model's raw residual,
    `misfit_deg` the same with the sensor's offset and slow drift taken out, `scored` the
    samples that are data. None where the recording has too little at rest. The noise is the
    spread about each stretch's line (rest_noise): what slow physics moves is not noise."""
    rest = rest_noise(residual_deg, scored, pressure_kpa, rate_hz, finger, about_line=True)
    if rest is None:
        return None
    rest_std = float(np.sqrt(np.mean(rest * rest)))
    if rest_std <= 0.0:
        return None
    return NoiseBound(rest_std, misfit_std(misfit_deg, scored), rest.size / rate_hz)


def misfit_std(misfit_deg: np.ndarray, scored: np.ndarray) -> float:
    """The misfit's spread over the scored samples, about its mean."""
    m = misfit_deg[scored]
    m = m - m.mean()
    return float(np.sqrt(np.mean(m * m)))


__all__ = ["NoiseBound", "bound", "bounded_order", "rest_noise", "rest_stretches", "slowest_decay_s"]
