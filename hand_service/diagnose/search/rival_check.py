"""A rival before the grade `complete`: pressure stiffening (searched on request) and creep
(searched behind the screen) not fitted by the search, fitted in place of the named ones,
judged on the raw angle.

Behind the screen (search/admission.py) they are fitted only where their screen and the raw
angle set them apart from the eight. Elsewhere a finger whose pressure stiffens it, or
whose material creeps, is named by the eight's effect that imitates it best (a stiffening
chamber as gravity or a cubic spring, creep as an asymmetric spring or a valve lag), and
where the imitation follows the recording to its noise the grade was `complete`
(docs/results.md §12.36, §12.38). Fitting them ungated moves the wrong names rather than
removing them (a stiffening stood in for a missing gravity).

So, wherever the verdict would be `missing_physics`, each rival (RIVALS,
those of them not searched past the screen and not in the model) is fitted in place of the
named effects, from the plain refit, as a first round fits a candidate
(forward_selection.beside), on the innovations like the named model; both are then
simulated from the recorded command alone and scored on the raw angle, each with one
constant offset and no drift (fitting/raw_error.py). A rival that gains on the plain model
as an effect must (Candidate.significant: it would be named had it been searched) and
follows the raw angle as well as the named model (a test on their squared raw errors'
difference cannot find it worse: fitting/raw_difference.py), or better, or within the raw
angle's tie even where the test finds it worse (within raw_error.TIE_SHARE of its RMS error,
or both within raw_error.TIE_NOISE times the noise: Rival.tied), stands: the grade is
then `dominant`, the rival said in `structure_left` and the JSON's `rival`. Where it ties,
the names stay: the rival was not searched for, and the user can ask for it (`--search`).
Where the raw angle favours it (`Rival.better`), the named effects do not beat another
effect on the raw signal, and nothing is named: the verdict is `unexplained`, the named
effects go to `partial_effects` and the sentence says which effect to ask for. In the truth
battery that was a chamber stiffening with pressure named `gravity` (`dominant`), and an
outside probe's gain saturating with pressure named gravity and a cubic spring, where the
stiffening followed the raw angle 27 % closer. Where structure is left (the grade
`dominant` already) a rival that stands changes nothing and goes unsaid; one the raw angle
favours still leaves nothing named (the probe's second saturating gain: the stiffening
33 % closer than gravity and a cubic spring, graded `dominant` for the structure left).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from hand_service.config import effects as fx
from hand_service.diagnose.fitting.output_error import Fit
from hand_service.diagnose.fitting.raw_difference import LEVEL, LossDifference, loss_difference
from hand_service.diagnose.fitting.raw_error import (
    TIE_NOISE,
    TIE_SHARE,
    both_at_noise,
    raw_misfit_deg,
    raw_rms_deg,
)
from hand_service.diagnose.model.problem import Problem
from hand_service.diagnose.search.forward_selection import Candidate, beside
from hand_service.diagnose.workers import ordered_map

# The effects searched behind the screen that can stand in for one of the eight over a whole
# recording: static or slow (a contact and a material's hysteresis have their own checks,
# outside_library/; a vent lag only refines a lag already named).
RIVALS = ("pressure_stiffening", "creep")
# Each rival is fitted from its screen's most promising start first, and from its other
# starts only where that fit gains anything (ΔBIC above 0; forward_selection.score's
# `lazy`): a rival stands only on a gain above SIGNIFICANT_BIC. On the battery slice's rival
# checks no rival's standing changed so (docs/results.md §12.49).
LAZY_STARTS = True


@dataclass(frozen=True)
class Rival:
    """A rival fitted in place of the named effects, and both on the raw angle (deg): their
    RMS errors and the test of their squared errors' difference (raw_difference.py)."""

    name: str
    named: tuple[str, ...]
    estimate: dict[str, float]  # the rival's fitted parameters
    delta_bic: float  # its gain on the plain refit, on the innovations
    significant: bool  # it would be named had it been searched (Candidate.significant)
    rival_raw_deg: float
    named_raw_deg: float
    noise_deg: float  # the sensor's noise as the fits estimate it
    difference: LossDifference  # the rival's squared raw error less the named model's
    loop: bool = False  # a loop in place of every named effect (loop_rival.py), not an on-request effect

    @property
    def better(self) -> bool:
        """The rival follows the raw angle better, beyond the recording's fluctuation."""
        return self.difference.b_better

    @property
    def worse(self) -> bool:
        """The named model follows the raw angle better, beyond the recording's fluctuation."""
        return self.difference.b_worse

    @property
    def tied(self) -> bool:
        """Worse, by the test, yet as close as the raw angle's tie: within TIE_SHARE of the
        named model's raw error, or both at the sensor's noise (raw_error.at_noise). Two
        stand-ins for physics of neither form can differ reliably by a per cent or two; the
        named one is then no more the physics than the rival."""
        return self.within_share or both_at_noise(self.named_raw_deg, self.rival_raw_deg, self.noise_deg)

    @property
    def within_share(self) -> bool:
        return self.rival_raw_deg <= (1.0 + TIE_SHARE) * self.named_raw_deg

    @property
    def stands(self) -> bool:
        """A rival that would be named had it been searched, which the raw angle cannot tell
        from the named model, or which follows it better, or comes within its tie."""
        return self.significant and bool(np.isfinite(self.rival_raw_deg)) and (not self.worse or self.tied)

    def sentence(self) -> str:
        said = ", ".join(self.named)
        model = f"the model with {said}"
        dm = self.difference
        test = (f"their squared errors differ by {dm.mean_deg2:.3g} deg² on average, t = {dm.statistic:.2f} "
                f"over {dm.blocks} stretches of {dm.block_samples} samples against {dm.critical:.2f} at "
                f"{100.0 * LEVEL:.0f} %")
        if self.better:
            how = f"follows the recorded angle better than {model}"
            tail = "the recording favours it, so no effect is named (see partial_effects)"
        elif self.worse:
            close = (f"within {100.0 * TIE_SHARE:.0f} %" if self.within_share
                     else f"both within {TIE_NOISE:g} times the sensor's noise, {self.noise_deg:.3g} deg")
            how = f"follows the recorded angle nearly as {model} does ({close}), if reliably less closely"
            tail = "two forms of other physics than the named can come that close"
        else:
            how = f"follows the recorded angle as {model} does, within what the recording can tell apart"
            tail = "the recording cannot tell them apart"
        values = ", ".join(f"{k} {v:.3g}" for k, v in self.estimate.items())
        what = ("a rate-independent loop in Dahl's form, the library's hysteresis" if self.loop
                else "not fitted by the search")
        advice = ("diagnose --search hysteresis weighs the loop as a candidate, past the screen" if self.loop
                  else f"diagnose --search {self.name} weighs it as a candidate")
        return (f"{self.name} ({values}), {what}, fitted in place of {said}, {how}: raw "
                f"RMS error {self.rival_raw_deg:.3g} against {self.named_raw_deg:.3g} deg, each simulated "
                f"from the recorded command with a constant offset alone ({test}; ΔBIC "
                f"{self.delta_bic:.0f} over the plain model); "
                f"{tail if self.better else tail + ', so the grade is not complete'} ({advice})")

    def to_json(self) -> dict:
        dm = self.difference
        return {"name": self.name, "in_place_of": list(self.named), "params": dict(self.estimate),
                "delta_bic": self.delta_bic, "raw_rmse_deg": self.rival_raw_deg,
                "named_raw_rmse_deg": self.named_raw_deg, "noise_deg": self.noise_deg, "better": self.better,
                "squared_error_difference_deg2": dm.mean_deg2, "difference_stderr_deg2": dm.stderr_deg2,
                "difference_t": dm.statistic, "difference_critical_t": dm.critical, "blocks": dm.blocks,
                "block_samples": dm.block_samples,
                "loop": self.loop}


def rivals_to_try(search: Sequence[str], in_model: Iterable[str]) -> list[str]:
    """RIVALS not searched already and not part of the model."""
    held = set(search) | set(in_model)
    return [name for name in RIVALS if name not in held]


def estimate_of(candidate: Candidate) -> dict[str, float]:
    """The rival's fitted parameters, by name (its size, then its fitted shape)."""
    f, size = candidate.fit, fx.BY_NAME[candidate.name].param
    return {p.member or size: float(v) for p, v in zip(f.params, f.values, strict=True)
            if p.is_effect and p.label == candidate.name}


def fitted_rivals(problem: Problem, refit: Fit, final: Fit, named: Sequence[str], rivals: Sequence[str],
           fitting: np.ndarray, scored: np.ndarray, noise_deg: float) -> list[Rival]:
    """Each rival fitted from the plain refit (`beside`, LAZY_STARTS), side by side, against `final`, the
    model with the `named` effects, on the raw angle; `noise_deg` the sensor's noise the fits
    estimate."""
    named_raw = raw_rms_deg(problem, final.angle_deg, fitting, scored)
    named_err = raw_misfit_deg(problem, final.angle_deg, fitting, scored)
    out = []
    for candidate in ordered_map(lambda name: beside(problem, refit, name, lazy=LAZY_STARTS), rivals):
        angle = candidate.fit.angle_deg
        finite = bool(np.all(np.isfinite(angle)))
        raw = raw_rms_deg(problem, angle, fitting, scored) if finite else float("inf")
        difference = (loss_difference(named_err, raw_misfit_deg(problem, angle, fitting, scored)) if finite
                      else LossDifference(float("inf"), 0.0, 0, 0, int(scored.sum())))
        out.append(Rival(candidate.name, tuple(named), estimate_of(candidate), float(candidate.delta_bic),
                         candidate.significant, raw, named_raw, noise_deg, difference))
    return out


def strongest(problem: Problem, refit: Fit, final: Fit, named: Sequence[str], rivals: Sequence[str],
              fitting: np.ndarray, scored: np.ndarray, noise_deg: float,
              better_only: bool = False) -> Rival | None:
    """The rival that stands (Rival.stands) with the lowest raw error, or None; with
    `better_only` (structure left: the grade is `dominant` already), of those the raw angle
    favours (Rival.better) only."""
    if not rivals:
        return None
    every = fitted_rivals(problem, refit, final, named, rivals, fitting, scored, noise_deg)
    standing = [r for r in every if r.stands and (r.better or not better_only)]
    return min(standing, key=lambda r: r.rival_raw_deg, default=None)
