"""The verdict of `diagnose`, in words: what the found effects explain, what structure
remains, and which answer the evidence allows (consistent, parameters_only,
missing_physics with its grade, unexplained, insufficient_excitation)."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from hand_service.config import effects as fx
from hand_service.diagnose.fitting.output_error import Fit
from hand_service.diagnose.fitting.raw_error import TIE_SHARE, RawJudgement
from hand_service.diagnose.model.params import Param
from hand_service.diagnose.model.problem import PLAIN, PRIOR_RELATIVE_WIDTH, Problem
from hand_service.diagnose.residual import noise, stats
from hand_service.diagnose.search.effect_size import SizeEstimate
from hand_service.diagnose.search.forward_selection import Selection
from hand_service.diagnose.search.prior_evidence import prior_chi2

STRUCTURE_P = 1e-6  # Ljung-Box p-value below which a residual is clearly structured
# An effect whose signature k, B and N absorb all but this share of could hide in a refit:
# an effect ten times the noise would leave less than the noise behind.
SEPARABLE_MIN = 0.1


@dataclass
class FoundEffect:
    name: str
    value: float
    std: float
    evidence: str
    delta_bic: float
    z_heldout: float
    signature_corr: float
    # its shape parameters fitted beside its size (an onset, a travel, a time) and their stds
    shape: dict[str, float] = field(default_factory=dict)
    shape_std: dict[str, float] = field(default_factory=dict)
    # what the recording fixes where the size trades with the shape (a contact's spring torque)
    size: SizeEstimate | None = None

    @property
    def params(self) -> dict[str, float]:
        """Every parameter fitted: its size, then its shape."""
        return {fx.BY_NAME[self.name].param: self.value, **self.shape}

    def to_json(self) -> dict:
        param = fx.BY_NAME[self.name].param
        return {"name": self.name, "params": self.params, "evidence": self.evidence,
                "std": {param: self.std, **self.shape_std}, "delta_bic": self.delta_bic,
                "heldout_z": self.z_heldout, "signature_corr": self.signature_corr,
                **({} if self.size is None else {"derived": asdict(self.size)})}


DOMINANT_SHARE = 0.6  # the share of the mismatch an effect must explain to be named over structure
DOMINANT_RELATIVE_STD = 0.2  # and its estimate must be this well determined


def plural(names: list, verb: str) -> str:
    """`verb` agreeing with a list of one or more subjects: "reduces" for one."""
    return verb + "s" if len(names) == 1 else verb


def dominant(found: list[FoundEffect], explained: float) -> bool:
    """The graded verdict for real rigs: the effects explain most of the mismatch and the
    first is well determined, though structure outside the library remains."""
    first = found[0]
    value, std = (first.value, first.std) if first.size is None else (first.size.value, first.size.std)
    return explained >= DOMINANT_SHARE and abs(std) <= DOMINANT_RELATIVE_STD * abs(value)


def late_structure(found: list[FoundEffect], left: str, raw: RawJudgement) -> tuple[bool, str]:
    """Structure the noise-only measures find (`left`) beside the named model's white
    innovations: its evidence passed a noise model that took structure, so the names stand
    (graded `dominant`) only where the raw angle asks for them too, closer than the plain
    model beyond the raw tie. (Whether they stand, the sentence to print.)"""
    if raw.closer_than_tie():
        return True, left
    names = ", ".join(e.name for e in found)
    one = len(found) == 1
    return False, (f"{names} {plural(found, 'fit')} the innovations, but {left}; and on the raw angle "
                   f"the model with {'it' if one else 'them'} follows the recording within "
                   f"{100 * TIE_SHARE:.0f} % of the plain model ({raw.numbers()}): so "
                   f"{'it is' if one else 'they are'} not named (see partial_effects)")


def explained_share(problem: Problem, refit: Fit, final: Fit) -> float:
    """How much of the refitted plain model's mismatch the augmented model explains: the
    drop of the squared misfit over what lies above the noise floor (the variance a
    fitted AR filter cannot predict in the augmented model's misfit), 0 to 1."""
    mask = problem.fit_mask
    before, after = problem.misfit(refit.angle_deg)[mask], problem.misfit(final.angle_deg)[mask]
    floor = noise.estimate(after, np.ones(after.size, bool), problem.rate_hz, with_drift=False)
    floor_deg2 = after.size * floor.innovation_std_deg**2
    excess = float(before @ before) - floor_deg2
    if excess <= 0.0:
        return 0.0
    return float(np.clip((before @ before - after @ after) / excess, 0.0, 1.0))


def prior_share(problem: Problem, refit: Fit, final: Fit) -> float:
    """Where the plain refit had to go far from the nominal (its prior counted as evidence,
    search.PRIOR_EVIDENCE_FACTOR), that distance is the mismatch too: the share of the
    refit's prior χ² the augmented model removes, 0 to 1. A slow valve that the refit
    mimicked by scaling k, B and N together leaves the misfit where it was and brings the
    parameters home: its misfit share is 0, this share near 1."""
    before, after = prior_chi2(problem, refit), prior_chi2(problem, final)
    return float(np.clip((before - after) / before, 0.0, 1.0)) if before > 0.0 else 0.0


TRADE_OFF_CORR = 0.95  # an effect this correlated with a plain parameter trades off with it
TRADE_OFF_RELATIVE_STD = 0.1  # when it is known worse than this


def trade_offs(final: Fit, found: list[FoundEffect]) -> list[str]:
    """Found effects whose estimate this recording ties to k, B or N: said plainly (on an
    over-damped finger a valve lag and extra damping make nearly the same response)."""
    labels = [p.label for p in final.params]
    corr = final.correlation()
    said = []
    for effect in found:
        if not abs(effect.std) > TRADE_OFF_RELATIVE_STD * abs(effect.value):
            continue  # well determined whatever it correlates with
        i = labels.index(effect.name)
        for j, label in enumerate(labels):
            if label in PLAIN and abs(corr[i, j]) > TRADE_OFF_CORR:
                what = {"damping_nms_per_rad": "extra damping B", "stiffness_nm_per_rad": "the stiffness k",
                        "pressure_gain_nm_per_kpa": "the pressure gain N"}[label]
                said.append(f"{effect.name} trades off with {what} in this recording (correlation "
                            f"{corr[i, j]:+.2f}): the data tell them apart only weakly, so read its "
                            f"estimate with {label}'s")
    return said


def structure_left(white: stats.Whiteness, cross: stats.Whiteness) -> str:
    """What in a model's innovations says it misses something, in words; '' if nothing.
    The input test speaks first: an output that answers something other than the modelled
    input is the plainer reason."""
    reasons = []
    if cross.p_value < STRUCTURE_P:
        reasons.append(f"the residual still follows the input (cross-correlation with the prewhitened "
                       f"command, p = {cross.p_value:.1g}): the output answers the input, or something "
                       "besides it, in a way the model does not")
    if white.p_value < STRUCTURE_P:
        reasons.append(f"a structured residual remains (Ljung-Box p = {white.p_value:.1g})")
    return "; and ".join(reasons)


HELD_NEAR = 1.0 + 3.0 * PRIOR_RELATIVE_WIDTH  # within this factor of the nominal, a value is held near it


def unpinned_sentence(unidentified: list[str], held_at: dict[str, float], advice: str) -> str:
    """What the prior holds, without an uncertainty beside "held near" (the data alone leave
    those parameters unknown) and without calling a value held near that the fit took far."""
    far = {label: r for label, r in held_at.items() if not 1.0 / HELD_NEAR <= r <= HELD_NEAR}
    near = [label for label in unidentified if label not in far]
    text = (f"the recording alone cannot pin {', '.join(unidentified)} (unknown from the data alone): "
            f"the nominal's uncertainty (a prior of ±{100 * PRIOR_RELATIVE_WIDTH:.0f} %) is added to the fit")
    if near:
        text += f", which holds {', '.join(near)} near the nominal"
    if far:
        text += "; " + ", ".join(f"{label} is refitted to {r:.3g} times the nominal even so"
                                 for label, r in far.items())
    return f"{text}, and the effects are tested against that; {advice}"


def judge(unidentified: list[str], params: list[Param], relative_std: np.ndarray, selection: Selection,
          found: list[FoundEffect], refit_tests: tuple[stats.Whiteness, stats.Whiteness],
          final_tests: tuple[stats.Whiteness, stats.Whiteness],
          refit_gain_z: float, refit_bic: float, inseparable: list[str],
          warnings: list[str], advice: str = "",
          explained: float = 0.0, held_at: dict[str, float] | None = None) -> tuple[str, list[str]]:
    """The verdict. `advice`: what this recording's command holds and lacks, in words.
    `held_at`: the refitted value over the nominal of each parameter the prior holds."""
    notes: list[str] = []
    if unidentified:
        warnings.append(unpinned_sentence(unidentified, held_at or {}, advice))
    if selection.ambiguous is not None:
        a, b = selection.ambiguous
        warnings.append(f"{a.name} and {b.name} explain the residual about equally well (ΔBIC "
                        f"{a.delta_bic:.0f} and {b.delta_bic:.0f}) and not better together: this "
                        "recording cannot tell them apart")
        if found:
            warnings.append(f"{a.name} is kept in the model, unnamed, while the search goes on: what "
                            "is named beside it was found with one of the two in the model")
        if not found:
            return "insufficient_excitation", notes
    if found:
        left = structure_left(*final_tests)
        if left and dominant(found, explained):
            notes.append(f"{found[0].name} is the dominant missing physics: with "
                         f"{'it' if len(found) == 1 else 'them'} the model explains "
                         f"{100 * explained:.0f} % of the mismatch, but {left}: something outside the "
                         "library remains")
            return "missing_physics", notes
        if left:
            names = ", ".join(e.name for e in found)
            one = len(found) == 1
            warnings.append(f"{names} {plural(found, 'reduce')} the residual, but {left}: "
                            f"{'it explains' if one else 'they explain'} only part of the "
                            f"mismatch ({100 * explained:.0f} %), so {'it is' if one else 'they are'} "
                            "not named (see partial_effects)")
            return "unexplained", notes
        return "missing_physics", notes
    left = structure_left(*refit_tests)
    if left:
        warnings.append(f"the refitted model leaves a mismatch that no library effect explains: {left}")
        return "unexplained", notes
    if unidentified:
        return "insufficient_excitation", notes
    if inseparable:
        warnings.append(f"this recording cannot tell {', '.join(inseparable)} from a change of k, B and N "
                        f"(k, B and N absorb over {100 * (1 - SEPARABLE_MIN):.0f} % of "
                        f"{'its' if len(inseparable) == 1 else 'their'} signature): the refit may be "
                        f"hiding it; {advice}")
        return "insufficient_excitation", notes
    if refit_bic > 10.0 and refit_gain_z > 3.0:
        notes.append("the refit predicts held-out data better than the nominal model "
                     f"(z = {refit_gain_z:.1f})")
        return "parameters_only", notes
    return "consistent", notes
