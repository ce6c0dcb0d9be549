"""A rival before the grade `complete`: the effects searched only on request, fitted in place
of the named ones, judged on the raw angle.

The default search tries the library's searched effects only. A finger whose pressure
stiffens it, or whose material creeps, is then named by the searched effect that imitates
it best (a stiffening chamber as gravity or a cubic spring, creep as an asymmetric spring or
a valve lag), and where the imitation follows the recording to its noise the grade was
`complete` (docs/results.md §12.36, §12.38). Searching those effects by default moves the
wrong names rather than removing them (a stiffening stood in for a missing gravity).

So, where the verdict would be `missing_physics` graded `complete`, each rival (RIVALS,
those of them not searched and not in the model) is screened and fitted in place of the
named effects, from the plain refit, as a first round fits a candidate
(forward_selection.beside), on the innovations like the named model; both are then
simulated from the recorded command alone and scored on the raw angle, each with one
constant offset and no drift (fitting/raw_error.py). A rival that gains on the plain model
as an effect must (Candidate.significant: it would be named had it been searched) and
follows the raw angle as well as the named model (within raw_error.TIE_SHARE of its RMS
error, or both within raw_error.TIE_NOISE times the noise), or better, stands: the grade is
then `dominant`, the rival said in `structure_left` and the JSON's `rival`. The names stay:
the rival was not searched for, and the user can ask for it (`--search`).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from hand_service.config import effects as fx
from hand_service.diagnose.fitting.output_error import Fit
from hand_service.diagnose.fitting.raw_error import TIE_NOISE, TIE_SHARE, at_noise, raw_rms_deg
from hand_service.diagnose.model.problem import Problem
from hand_service.diagnose.search.forward_selection import Candidate, beside
from hand_service.diagnose.workers import ordered_map

# The effects searched only on request that can stand in for a searched one over a whole
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
    """A rival fitted in place of the named effects, and both on the raw angle (deg)."""

    name: str
    named: tuple[str, ...]
    estimate: dict[str, float]  # the rival's fitted parameters
    delta_bic: float  # its gain on the plain refit, on the innovations
    significant: bool  # it would be named had it been searched (Candidate.significant)
    rival_raw_deg: float
    named_raw_deg: float
    noise_deg: float  # the sensor's noise as the fits estimate it

    @property
    def better(self) -> bool:
        """The rival follows the raw angle better by more than the raw angle's tie."""
        return self.rival_raw_deg < (1.0 - TIE_SHARE) * self.named_raw_deg

    @property
    def within_share(self) -> bool:
        return self.rival_raw_deg <= (1.0 + TIE_SHARE) * self.named_raw_deg

    @property
    def both_at_noise(self) -> bool:
        """Both follow the raw angle to the sensor's noise (raw_error.at_noise)."""
        return at_noise(self.named_raw_deg, self.noise_deg) and at_noise(self.rival_raw_deg, self.noise_deg)

    @property
    def stands(self) -> bool:
        """A rival that would be named had it been searched, as good on the raw angle as the
        named model (within TIE_SHARE, or both at the noise), or better."""
        return (self.significant and bool(np.isfinite(self.rival_raw_deg))
                and (self.within_share or self.both_at_noise))

    def sentence(self) -> str:
        said = ", ".join(self.named)
        model = f"the model with {said}"
        if self.better:
            how, tail = f"follows the recorded angle better than {model}", "the recording favours it"
        elif self.within_share:
            how = f"follows the recorded angle as well as {model} (within {100.0 * TIE_SHARE:.0f} %)"
            tail = "the recording cannot tell them apart"
        else:
            how = (f"follows the recorded angle to the sensor's noise ({self.noise_deg:.3g} deg; within "
                   f"{TIE_NOISE:g} times it) as {model} does, if less closely")
            tail = "a rival the default search does not try fits to the noise too"
        values = ", ".join(f"{k} {v:.3g}" for k, v in self.estimate.items())
        return (f"{self.name} ({values}), searched only on request, fitted in place of {said}, {how}: raw "
                f"RMS error {self.rival_raw_deg:.3g} against {self.named_raw_deg:.3g} deg, each simulated "
                f"from the recorded command with a constant offset alone (ΔBIC {self.delta_bic:.0f} over "
                f"the plain model); {tail}, so the grade is not complete "
                f"(diagnose --search {self.name} weighs it as a candidate)")

    def to_json(self) -> dict:
        return {"name": self.name, "in_place_of": list(self.named), "params": dict(self.estimate),
                "delta_bic": self.delta_bic, "raw_rmse_deg": self.rival_raw_deg,
                "named_raw_rmse_deg": self.named_raw_deg, "noise_deg": self.noise_deg, "better": self.better}


def rivals_to_try(search: Sequence[str], in_model: Iterable[str]) -> list[str]:
    """RIVALS not searched already and not part of the model."""
    held = set(search) | set(in_model)
    return [name for name in RIVALS if name not in held]


def estimate_of(candidate: Candidate) -> dict[str, float]:
    """The rival's fitted parameters, by name (its size, then its fitted shape)."""
    f, size = candidate.fit, fx.BY_NAME[candidate.name].param
    return {p.member or size: float(v) for p, v in zip(f.params, f.values, strict=True)
            if p.is_effect and p.label == candidate.name}


def strongest(problem: Problem, refit: Fit, final: Fit, named: Sequence[str], rivals: Sequence[str],
              fitting: np.ndarray, scored: np.ndarray, noise_deg: float) -> Rival | None:
    """The rival that stands with the lowest raw error, or None. Each rival is fitted from the
    plain refit (`beside`, LAZY_STARTS), side by side; `final` is the model with the `named` effects;
    `noise_deg` the sensor's noise the fits estimate."""
    if not rivals:
        return None
    named_raw = raw_rms_deg(problem, final.angle_deg, fitting, scored)
    fitted = ordered_map(lambda name: beside(problem, refit, name, lazy=LAZY_STARTS), rivals)
    standing = []
    for candidate in fitted:
        angle = candidate.fit.angle_deg
        raw = raw_rms_deg(problem, angle, fitting, scored) if np.all(np.isfinite(angle)) else float("inf")
        rival = Rival(candidate.name, tuple(named), estimate_of(candidate), float(candidate.delta_bic),
                      candidate.significant, raw, named_raw, noise_deg)
        if rival.stands:
            standing.append(rival)
    return min(standing, key=lambda r: r.rival_raw_deg, default=None)
