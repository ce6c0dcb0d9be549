"""Every model against the raw recorded angle: one constant sensor offset each, no drift.

The fits run on innovations, with the sensor's offset and slow drift as nuisance terms of
the noise model. A slow drift absorbs what a wrong gain does on a slow command (on a ramp,
a pressure gain 30 % off is a slope), so a figure of improvement measured after it flatters
exactly the wrong models. So every model compared here is simulated from the recorded
command alone, from the recording's initial state, and scored against the raw angle with
one constant offset and nothing else. The offset is each model's own (its mean misfit over
the fitting samples), not one shared by all: an effect can move the whole static map by a
constant (a dead zone d lowers every angle above it by N·d/k), and one offset fitted on the
plain model would charge that to the effect. A constant cannot take a slope, a step's
height or a ramp's gain, which are what a wrong N or k leaves.

The same figures judge whether the plain model follows the recording at all: a refitted
plain model whose simulation explains little of the recorded angle's variance (a wrong
gain, an input without authority over the motion, an unlogged second input) is said to be
so, and no effect is named on top of it.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from hand_service.diagnose.fitting.output_error import Fit, fit
from hand_service.diagnose.fitting.raw_difference import LEVEL, LossDifference, loss_difference
from hand_service.diagnose.model.problem import Problem
from hand_service.diagnose.recording.response_onset import white_noise_deg
from hand_service.diagnose.residual.noise import NoiseModel

# The plain model follows a recording when its simulation explains at least this share of
# the recorded angle's variance about its mean (raw, with the shared offset).
FOLLOW_SHARE = 0.5
# ... judged only where the misfit stands this many times above the sensor's white noise
# (a finger that barely moves leaves a misfit of noise, which says nothing of the model).
NOISE_MARGIN = 3.0
# A tie on the raw angle: both models within this many times the sensor's noise, the
# augmented one within this share of the plain one.
TIE_NOISE = 1.25
TIE_SHARE = 0.02


@dataclass(frozen=True)
class RawErrors:
    """RMS errors (deg) of each model's simulated angle against the recorded one, each with
    its own constant offset (fitted on the fitting samples): over every scored sample (raw)
    and over the held-out ones."""

    offset_deg: dict[str, float]
    raw_deg: dict[str, float]
    heldout_deg: dict[str, float]

    def to_json(self) -> dict:
        return {"sensor_offset_deg": dict(self.offset_deg), "raw_rmse_deg": dict(self.raw_deg)}


def offset_of(problem: Problem, angle_deg: np.ndarray, fitting: np.ndarray) -> float:
    """A model's constant sensor offset: its mean misfit over the fitting samples."""
    return float(np.mean(problem.residual(angle_deg)[fitting]))


def rms(problem: Problem, angle_deg: np.ndarray, offset_deg: float, mask: np.ndarray) -> float:
    r = problem.residual(angle_deg)[mask] - offset_deg
    return float(np.sqrt(np.mean(r * r))) if r.size else float("nan")


def raw_rms_deg(problem: Problem, angle_deg: np.ndarray, fitting: np.ndarray, scored: np.ndarray) -> float:
    """A model's RMS error on the raw angle over `scored`, with its own constant offset
    fitted on `fitting`."""
    return rms(problem, angle_deg, offset_of(problem, angle_deg, fitting), scored)


def raw_misfit_deg(problem: Problem, angle_deg: np.ndarray, fitting: np.ndarray,
                   scored: np.ndarray) -> np.ndarray:
    """A model's raw error over `scored` in time order, with its own constant offset fitted on
    `fitting` (offset_of)."""
    return problem.residual(angle_deg)[scored] - offset_of(problem, angle_deg, fitting)


def at_noise(raw_deg: float, noise_deg: float) -> bool:
    """A raw RMS error at the sensor's noise: within TIE_NOISE times it."""
    return raw_deg <= TIE_NOISE * noise_deg


def both_at_noise(a_raw_deg: float, b_raw_deg: float, noise_deg: float) -> bool:
    """Two models' raw RMS errors both at the sensor's noise (at_noise)."""
    return at_noise(a_raw_deg, noise_deg) and at_noise(b_raw_deg, noise_deg)


def raw_errors(problem: Problem, fitting: np.ndarray, held: np.ndarray,
               angles: dict[str, np.ndarray]) -> RawErrors:
    offsets = {name: offset_of(problem, a, fitting) for name, a in angles.items()}
    return RawErrors(offsets,
                     {name: rms(problem, a, offsets[name], fitting | held) for name, a in angles.items()},
                     {name: rms(problem, a, offsets[name], held) for name, a in angles.items()})


def explained_variance(problem: Problem, angle_deg: np.ndarray, offset_deg: float,
                       scored: np.ndarray) -> float:
    """The share of the recorded angle's variance about its mean that the simulated angle
    explains, 1 − SS(misfit)/SS(angle): 1 for a perfect model, negative for one that is
    worse than the mean."""
    y = problem.measured_deg[scored]
    spread = y - y.mean()
    total = float(spread @ spread)
    r = problem.residual(angle_deg)[scored] - offset_deg
    return 1.0 - float(r @ r) / total if total > 0.0 else 1.0


def cannot_follow(problem: Problem, refit_angle_deg: np.ndarray, fitting: np.ndarray,
                  scored: np.ndarray) -> str:
    """'' when the refitted plain model follows the recording; else the sentence that says it
    does not, with the numbers."""
    offset_deg = offset_of(problem, refit_angle_deg, fitting)
    if np.ptp(problem.pressure_kpa) == 0.0:
        return ""  # no command change: nothing for the model to follow
    misfit = rms(problem, refit_angle_deg, offset_deg, scored)
    if misfit <= NOISE_MARGIN * white_noise_deg(problem.measured_deg):
        return ""
    share = explained_variance(problem, refit_angle_deg, offset_deg, scored)
    if share >= FOLLOW_SHARE:
        return ""
    y = problem.measured_deg[scored]
    sim = refit_angle_deg[scored] + offset_deg
    explains = (f"explains {100.0 * share:.0f} % of the recorded angle's variance" if share > 0.0 else
                "explains none of the recorded angle's variance (the recording's mean fits it better)")
    return (f"the model cannot follow the recording: the refitted plain model, simulated from the "
            f"recorded command, {explains} (raw RMS error {misfit:.3g} deg; it runs at "
            f"{np.min(sim):.3g} to {np.max(sim):.3g} deg "
            f"against recorded {np.min(y):.3g} to {np.max(y):.3g} deg): a wrong gain or model, an input "
            "without authority over the motion, or an input left unlogged; no library effect is named "
            "on a model that does not follow the data")


def offset_only(n: int) -> NoiseModel:
    """A noise model of a constant offset and nothing else: fits on the raw angle."""
    return NoiseModel(0, np.full((n, 1), 1.0 / np.sqrt(n)), np.zeros(0), 0.0)


@dataclass(frozen=True)
class RawJudgement:
    """Does the augmented model follow the raw angle better than the plain one? Its raw RMS
    error (deg) against the refitted plain model's over every scored sample, its held-out one
    against the nominal's (a model that predicts held-out data worse than the nominal is
    bending to absorb something), and whether they come from fits on the raw angle
    (refitted) or from the fits on the innovations."""

    before_deg: float
    after_deg: float
    nominal_held_deg: float
    after_held_deg: float
    refitted: bool = False
    # refitted: the plain model's squared raw errors against the augmented one's
    # (raw_difference.py, B the plain model); the raw refit adds a parameter to a nested model,
    # which can only lower the fitting samples' error, so it follows only beyond the
    # recording's fluctuation
    difference: LossDifference | None = None

    @staticmethod
    def of(errors: RawErrors, refitted: bool = False) -> RawJudgement:
        raw, held = errors.raw_deg, errors.heldout_deg
        return RawJudgement(raw["before"], raw["after"], held["nominal"], held["after"], refitted)

    @staticmethod
    def named(errors: RawErrors) -> RawJudgement:
        """The judgement of the engine's figures (keys "refit" and "augmented")."""
        raw, held = errors.raw_deg, errors.heldout_deg
        return RawJudgement(raw["refit"], raw["augmented"], held["nominal"], held["augmented"])

    @property
    def follows(self) -> bool:
        return (self.after_deg < self.before_deg and self.after_held_deg < self.nominal_held_deg
                and (self.difference is None or self.difference.b_worse))

    def closer_than_tie(self) -> bool:
        """The augmented model follows the raw angle closer than the plain one by more than
        TIE_SHARE of the plain one's error: the raw angle itself asks for the effect."""
        return self.after_deg < (1.0 - TIE_SHARE) * self.before_deg

    def ties_at_noise(self, noise_deg: float) -> bool:
        """Both models follow the raw angle to the sensor's noise, the augmented one no worse
        (within TIE_SHARE), and it predicts the held-out samples better than the nominal: the
        raw angle alone cannot choose between the effect and the plain model's moved k, B, N."""
        no_worse = self.after_deg <= (1.0 + TIE_SHARE) * self.before_deg
        better_held = self.after_held_deg < self.nominal_held_deg
        return at_noise(self.before_deg, noise_deg) and no_worse and better_held

    def tie_sentence(self, names: list[str], how_far: str) -> str:
        said = ", ".join(names)
        return (f"on the raw angle alone the model with {said} and the plain model refitted {how_far} "
                f"follow the recording equally, both at the sensor's noise ({self.numbers()}): the name "
                "rests on the nominal model's uncertainty (±25 %), which the plain model leaves far behind")

    def numbers(self) -> str:
        return (f"raw RMS error {self.after_deg:.3g} against the plain model's {self.before_deg:.3g} deg, "
                f"held out {self.after_held_deg:.3g} against the nominal's {self.nominal_held_deg:.3g}")

    def sentence(self, names: list[str], first: RawJudgement | None = None) -> str:
        them = "it" if len(names) == 1 else "them"
        said = ", ".join(names)
        if self.follows:
            assert first is not None
            return (f"fitted on the innovations (a drift and the correlated noise taken out), the model "
                    f"with {said} does not follow the raw angle better ({first.numbers()}); refitted on "
                    f"the raw angle with a constant offset alone, it does ({self.numbers()})")
        how = "refitted on the raw angle with a constant offset alone" if self.refitted else "as fitted"
        verb = "fits" if len(names) == 1 else "fit"
        d = self.difference
        beyond = ("" if d is None or d.b_worse else
                  f" beyond the recording's fluctuation (the squared errors differ by {d.mean_deg2:.3g} deg² "
                  f"on average, t = {d.statistic:.2f} over {d.blocks} stretches against {d.critical:.2f} "
                  f"at {100 * LEVEL:.0f} %)")
        return (f"{said} {verb} the innovations, yet the model with {them}, simulated from the recorded "
                f"command alone ({how}), does not follow the recorded angle better{beyond} "
                f"({self.numbers()}): so no effect is named (see partial_effects)")


@dataclass(frozen=True)
class RawRefit:
    """The plain and augmented models refitted on the raw angle (a constant offset alone),
    their figures, and the judgement on them."""

    plain: Fit
    augmented: Fit
    errors: RawErrors
    judgement: RawJudgement


def effects_follow(problem: Problem, nominal_angle_deg: np.ndarray, refit: Fit, final: Fit,
                   fitting: np.ndarray, held: np.ndarray) -> tuple[RawJudgement, RawRefit | None]:
    """The augmented model against the refitted plain one (and, held out, the nominal) on
    the raw angle, each simulated from the recorded command alone with a constant offset of
    its own. The fits ran on innovations, where a drift term can take what a model does
    slowly wrong; where the augmented model as fitted does not follow the raw angle better,
    the plain and the augmented model are refitted on the raw angle (a constant offset, no
    drift, no correlated noise) from their fitted values, and compared again: (as fitted,
    the raw refit or None). Where the raw refit is what follows, it is the pair to report
    and to write: the figures printed are the ones the name stands on."""
    angles = {"nominal": nominal_angle_deg, "before": refit.angle_deg, "after": final.angle_deg}
    first = RawJudgement.of(raw_errors(problem, fitting, held, angles))
    if first.follows:
        return first, None
    raw_problem = dataclasses.replace(problem, noise=offset_only(problem.measured_deg.size))
    plain = fit(raw_problem, refit.params, refit.values)
    augmented = fit(raw_problem, final.params, final.values)
    named = {"nominal": nominal_angle_deg, "refit": plain.angle_deg, "augmented": augmented.angle_deg}
    errors = raw_errors(problem, fitting, held, named)
    scored = fitting | held
    difference = loss_difference(raw_misfit_deg(problem, augmented.angle_deg, fitting, scored),
                                 raw_misfit_deg(problem, plain.angle_deg, fitting, scored))
    again = RawJudgement(errors.raw_deg["refit"], errors.raw_deg["augmented"], errors.heldout_deg["nominal"],
                         errors.heldout_deg["augmented"], refitted=True, difference=difference)
    return first, RawRefit(plain, augmented, errors, again)
