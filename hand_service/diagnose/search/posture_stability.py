"""Does a posture-dependent effect hold across the recording's postures? A library form
with one parameter (a cubic spring's k3, gravity's G) claims the same value wherever the
finger is. Something outside the library that only acts in part of the range (an object
the finger meets above some angle, a stop) can pass for it over the whole recording,
often two of them together, yet its parameter, fitted on the lower and on the upper half
of the angles apart, disagrees. A Chow-type test: the two estimates must agree within
STABILITY_Z of their joint standard error, made more honest for noise correlated in time
(the white-noise error of a least-squares fit is too small by the long-run variance ratio
of the residual's AR model, taken up to MAX_INFLATION), or within half their mean."""

from __future__ import annotations

import copy
from dataclasses import dataclass

import numpy as np

from hand_service.diagnose.fitting.output_error import Fit, fit
from hand_service.diagnose.model.problem import Problem
from hand_service.diagnose.residual import noise
from hand_service.diagnose.search.forward_selection import Candidate, Selection
from hand_service.diagnose.workers import ordered_map

POSTURE_EFFECTS = ("cubic_stiffness", "gravity")  # one parameter for every angle
STABILITY_Z = 4.0  # the halves disagree beyond this many joint standard errors
# The long-run ratio is taken at most this large: on a residual that still holds the
# structure under test (an object's one-sided spring) it runs to 15 and would excuse any
# disagreement; the halves must then also differ by half their mean, a change of form,
# not a wobble of a well-determined value.
MAX_INFLATION = 2.0
MIN_RELATIVE_CHANGE = 0.5
MIN_HALF_SHARE = 0.25  # each half keeps at least this share of the fit's samples


@dataclass
class Stability:
    name: str
    low: float
    high: float
    z: float

    @property
    def relative_change(self) -> float:
        mean = 0.5 * (abs(self.low) + abs(self.high))
        return abs(self.low - self.high) / mean if mean > 0.0 else 0.0

    @property
    def holds(self) -> bool:
        return not (self.z > STABILITY_Z and self.relative_change > MIN_RELATIVE_CHANGE)

    def sentence(self) -> str:
        return (f"{self.name} does not hold across the recording's postures: fitted on the lower half "
                f"of the angles it is {self.low:.3g}, on the upper half {self.high:.3g} "
                f"({self.z:.1f} standard errors apart): the torque the recording asks for varies over "
                "the angle otherwise than this form does (as an object or a stop met in part of the range "
                "would, or a torque of another form)")


def long_run_ratio(residual: np.ndarray, rate_hz: float) -> float:
    """sqrt(long-run variance / variance) of a residual under its AR model (>= 1 in use)."""
    order = noise.choose_order(residual)
    if order == 0:
        return 1.0
    a, innovation_var = noise.yule_walker(residual, order)
    variance = float(noise.autocovariance(residual, 0)[0])
    denominator = abs(1.0 - float(a.sum()))
    if variance <= 0.0 or denominator < 1e-6:
        return 1.0
    return float(max(np.sqrt(innovation_var / denominator**2 / variance), 1.0))


def check(problem: Problem, final: Fit, names: list[str]) -> list[Stability]:
    """The posture-dependent effects among `names` whose halves disagree (an empty list when
    every one holds, or when the recording's angles do not split into two usable halves)."""
    mask = problem.fit_mask
    angle = final.angle_deg
    median = float(np.median(angle[mask]))
    halves = [mask & (angle <= median), mask & (angle > median)]
    if min(int(h.sum()) for h in halves) < MIN_HALF_SHARE * int(mask.sum()):
        return []
    labels = [p.label for p in final.params]
    targets = [n for n in names if n in POSTURE_EFFECTS and n in labels]
    if not targets:
        return []
    residual = problem.misfit(angle)[mask]
    inflation = min(long_run_ratio(residual, problem.rate_hz), MAX_INFLATION)

    def fit_half(half: np.ndarray) -> Fit:
        part = copy.copy(problem)
        part.fit_mask = half
        return fit(part, final.params, final.values)

    fits = ordered_map(fit_half, halves)  # each half its own fit, side by side
    failed = []
    for name in targets:
        i = labels.index(name)
        (low, high), (s_low, s_high) = ([f.values[i] for f in fits], [f.std()[i] for f in fits])
        spread = inflation * float(np.hypot(s_low, s_high))
        z = abs(low - high) / spread if spread > 0.0 else 0.0
        result = Stability(name, float(low), float(high), float(z))
        if not result.holds:
            failed.append(result)
    return failed


def later_unstable(problem: Problem, final: Fit, selection: Selection) -> list[Stability]:
    """The later accepted effects that do not hold across the recording's postures, when the
    first, fitted alone, does (else []: the first fails too, or none fails). A spring that
    stiffens faster than the cube over a one-way ramp (sinh) was named a cubic spring and
    gravity, whose halves then disagreed, and everything was withdrawn; the cubic alone
    holds. An object met above some angle fails with the cubic alone too, and stays
    `unexplained`."""
    names = [c.name for c in selection.accepted]
    failed = check(problem, final, names)
    if not failed or names[0] in {u.name for u in failed}:
        return []
    return [] if first_alone_unstable(problem, selection) else failed


def first_alone_unstable(problem: Problem, selection: Selection) -> list[Stability]:
    """The first accepted effect, fitted alone (its own round's fit), if it does not hold
    across the recording's postures (else []; [] too for an effect that is not
    posture-dependent). With later effects named beside it that hold, they are mending its
    form, not adding physics: over one side of the angles a cubic spring and a gravity load
    together make a two-term stiffening (θ² and θ³ beside k's θ) that fits an object met part
    way (Hunt-Crossley, δ^1.5 past 47°, with its own damping) across both halves, while the
    cubic alone fails. A spring that truly is cubic, or a true gravity load, holds alone with
    a second effect named beside it."""
    first = selection.accepted[0]
    return check(problem, first.fit, [first.name])


EVEN_ODD = {"gravity", "cubic_stiffness"}  # a torque even in θ (1 − cos θ), one odd (θ³)


def posture_advice(pair: tuple[Candidate, Candidate], angle_deg: np.ndarray) -> list[str]:
    """Why gravity and a cubic spring could not be told apart, when that is the pair: the
    recording bent the finger one way only, where an even torque and an odd one share
    most of their shape (past the linear part k takes, about a fifth of θ³ over 0 to
    75° is not 1 − cos θ); and what would tell them apart."""
    if {c.name for c in pair} != EVEN_ODD:
        return []
    low, high = float(np.percentile(angle_deg, 1)), float(np.percentile(angle_deg, 99))
    if low < -0.2 * high and high > -0.2 * low:
        return []  # it bent both ways: the pair is ambiguous for another reason
    return [f"the finger bent one way only here ({low:.0f}° to {high:.0f}°): over one side, gravity's "
            "torque (even in the angle, 1 − cos θ) and a cubic spring's (odd, θ³) share most of their "
            "shape; a recording that bends it both ways (a negative pressure, or a push), or one "
            "with the hand turned over, tells them apart"]
