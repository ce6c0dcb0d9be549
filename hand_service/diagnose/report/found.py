"""A named effect as the report gives it: its value, its spread, its shape and the sentence
that says it, the raw figures measured without and with it."""

from __future__ import annotations

import numpy as np

from hand_service.config import effects as fx
from hand_service.diagnose.fitting import raw_error
from hand_service.diagnose.model.problem import Problem
from hand_service.diagnose.report.evidence import Context, sentence
from hand_service.diagnose.report.verdict import FoundEffect
from hand_service.diagnose.search import effect_size
from hand_service.diagnose.search.forward_selection import Candidate, Selection, clear_of_zero


def velocity_deg_per_s(angle_deg: np.ndarray, rate_hz: float) -> np.ndarray:
    return np.gradient(angle_deg) * rate_hz


def found_effect(problem: Problem, c: Candidate, selection: Selection,
                 scored: tuple[np.ndarray, np.ndarray],
                 without_with: tuple[np.ndarray, np.ndarray] | None = None) -> FoundEffect:
    """`scored`: the fitting and held-out samples of the raw figures; `without_with`: the
    angles the raw figures compare (default: the round's base and the candidate's fit)."""
    final = selection.final
    assert final is not None
    value = final.value(c.name)
    stds = final.std()
    std = float(stds[[p.label for p in final.params].index(c.name)])
    shape = final.shape(c.name)
    shape_std = {p.member: float(s) for p, s in zip(final.params, stds, strict=True)
                 if p.label == c.name and p.member}
    angle = final.angle_deg
    named_in = next((r for r in selection.rounds if c in r.candidates), None)
    context = Context(problem, angle, velocity_deg_per_s(angle, problem.rate_hz),
                      final.value("stiffness_nm_per_rad"), final.value("damping_nms_per_rad"), value, shape,
                      {} if named_in is None else {x.name: float(x.delta_bic) for x in named_in.candidates})
    if without_with is None:
        assert named_in is not None
        without_with = (named_in.base.angle_deg, c.fit.angle_deg)
    # without and with the effect, against the raw angle, a constant offset each
    errors = raw_error.raw_errors(problem, *scored, {"before": without_with[0], "after": without_with[1]})
    size = effect_size.derived_size(final, c.name)
    alone = None
    if size is not None and c.core_determined and not clear_of_zero(size):
        # named on the refit without its refining parameters: say so, and what that refit fixes
        spec = fx.BY_NAME[c.name]
        held = ", ".join(f"{m} = {spec.parameter(m).neutral:g}" for m in spec.refining)
        alone = (c.core_size.value, c.core_size.std, f"refitted with {held}")
    text = sentence(c.name, context, std, c.delta_bic, c.z_heldout, errors, c.prior_gain,
                    {member: (value, shape_std[member]) for member, value in shape.items()},
                    None if size is None else (size.what, size.value, size.std, size.unit), alone)
    return FoundEffect(c.name, value, std, text, c.delta_bic, c.z_heldout, c.signature_corr, shape, shape_std,
                       size)
