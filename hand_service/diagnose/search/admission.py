"""Which screened effects a round fits: the effects that can stand in for the others' physics
(Effect.admitted_by_screen: a contact, a material's loop, a pressure-stiffened spring, creep)
only where the screen sets them apart and, fitted, they follow the raw angle better than the
eight's fits of the round; and a loop named over dry friction only where it follows the raw
angle better.

A stand-in fitted beside the library's other effects wins by a few per cent of ΔBIC where
the truth is neither form (a stiffening chamber for a missing gravity, a Dahl loop for dry
friction: docs/results.md §12.30, §12.38), and each of its fits costs what the others' do
(a Dahl loop's, on a ringing recording, four times a round's). So such an effect is fitted
only where its screen's gain on the innovations (Screen.predicted_white_bic, the readjusted
scan's best point) beats the best of the other effects' screens by the naming margin (the
ΔBIC by which a name must beat its runner-up, forward_selection.NAME_MARGIN_BIC): short of
it, the fit could at best tie with an effect the screen already ranks ahead. An effect the
model file gives (its shape where the lab's object sits, or where the residual's torque
switches on: requested.py) or the user asks for by name (`--search`) is fitted whatever its
screen: the screen sees an effect's size at its shape's start only, and a contact met past
another onset than that start's can screen below a cubic spring and fit far above it.

Dahl's loop narrows to dry friction as its travel shrinks: a loop that dry friction also
draws is one physics to the recording. Where the round's best is the loop, it is named only
when its model, simulated from the recorded command, follows the raw angle better than dry
friction's by more than the raw angle's tie (raw_error.TIE_SHARE) and not both at the noise;
else the two are a tie (Selection.ambiguous), said so.

Past the screen, a stand-in's win on the innovations is not yet the physics: beside a valve
lag, a stiffening chamber gained more ΔBIC than the gravity it stood in for while following
the raw angle no better (docs/results.md §12.52, §12.57). So a stand-in the screen let in
stays in its round only where it is significant and its model, simulated from the recorded
command, follows the raw angle better than every significant fit of the eight's in the round
(the loop beside dry friction excepted: the tie above judges that pair), in a later round
better than the model before it, and, where it leads the eight's best in ΔBIC, better than
the eight's best two fitted together, each by more than the raw angle's tie share (at the
noise too: a loop 17 % closer than a cubic spring, both within 1.25 times the noise, was the
truth's loop, and one of the two is named); a later round's stand-in must also follow the raw
angle closer than the model so far, and not both at the noise (a stiffening 7 % closer than a
cubic spring and gravity at the noise, on a spring stiffer than the cube, was a third name for
one physics): else the eight's explanation, or the model so far, stands (`kept`). The pair is
one physics the eight draw as two: a weight mounted at an angle is the library's gravity
and a cubic spring (k takes its linear part); a stiffening chamber drew it in one, closer
than gravity alone but not than the two (docs/results.md §12.57).

Where the first round's two best of the eight tie (both significant, within the naming
margin), the eight have no name for the residual, and the stand-ins the screen kept out are
fitted too: each joins the round only where it is significant and follows the raw angle
closer than both tied effects by more than the tie share (`beside_a_tie`), and `kept` then
judges it as any stand-in (a contact under PI steps, the finger bent one way: gravity and a
cubic spring tied, the contact's screen below the cubic's, fitted far above both, §12.60).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol, TypeVar

import numpy as np

from hand_service.config import effects as fx
from hand_service.diagnose.fitting.output_error import Fit
from hand_service.diagnose.fitting.raw_error import TIE_SHARE, both_at_noise, raw_rms_deg
from hand_service.diagnose.model.problem import Problem
from hand_service.diagnose.search.screening import Screen


class Fitted(Protocol):
    """What the loop-or-friction check reads of a candidate (forward_selection.Candidate)."""

    name: str
    fit: Fit


Candidate = TypeVar("Candidate", bound=Fitted)

LOOP = "hysteresis"
FRICTION = "coulomb_friction"


def gated(problem: Problem, name: str) -> bool:
    """Effect `name` is fitted only past the screen: neither given by the model file nor
    asked for by name (`--search`, Problem.asked)."""
    return (fx.BY_NAME[name].admitted_by_screen and name not in problem.given_effects
            and name not in problem.asked)


def admitted(problem: Problem, screens: list[Screen], margin_bic: float) -> list[Screen]:
    """`screens` without the gated effects whose predicted gain on the innovations does not
    beat every ungated screen's by `margin_bic` (all of them kept where none is ungated)."""
    bar = margin_bic + max((s.predicted_white_bic for s in screens if not gated(problem, s.name)),
                           default=-np.inf)
    return [s for s in screens if not gated(problem, s.name) or s.predicted_white_bic > bar]


def raw_deg(problem: Problem, angle_deg: np.ndarray) -> float:
    """A fit's RMS error on the raw angle, its own constant offset, over the fitting and
    held-out samples (raw_error.raw_rms_deg); infinite for a diverged finger."""
    if not np.all(np.isfinite(angle_deg)):
        return float("inf")
    return raw_rms_deg(problem, angle_deg, problem.fit_mask, problem.fit_mask | problem.held_mask)


def beats_on_raw(own_raw_deg: float, other_raw_deg: float, noise_deg: float) -> bool:
    """A model follows the raw angle better than another by more than the raw angle's tie,
    and the two are not both at the sensor's noise."""
    return (own_raw_deg < (1.0 - TIE_SHARE) * other_raw_deg
            and not both_at_noise(own_raw_deg, other_raw_deg, noise_deg))


def loop_beats_friction(loop_raw_deg: float, friction_raw_deg: float, noise_deg: float) -> bool:
    """The loop follows the raw angle better than dry friction (beats_on_raw)."""
    return beats_on_raw(loop_raw_deg, friction_raw_deg, noise_deg)


def closer_on_raw(own_raw_deg: float, other_raw_deg: float) -> bool:
    """A model follows the raw angle better than another by more than the raw angle's tie
    share, whatever the noise: at the noise the innovations have judged its gain real, and
    what is asked of the raw angle is that the other's explanation does not come as close."""
    return own_raw_deg < (1.0 - TIE_SHARE) * other_raw_deg


class Judged(Fitted, Protocol):
    """What `kept` reads of a round's candidate (forward_selection.Candidate)."""

    @property
    def significant(self) -> bool: ...


Scored = TypeVar("Scored", bound=Judged)


def paired(stand_in: str, other: str) -> bool:
    """The stand-in and one of the eight judged by their own rule (the loop and dry friction)."""
    return stand_in == LOOP and other == FRICTION


def kept(problem: Problem, base: Fit, candidates: list[Scored], later: bool,
         fit_pair: Callable[[Fit, str], Fitted]) -> list[Scored]:
    """A round's `candidates` (strongest first) without the stand-ins the screen let in
    (gated) that are not significant, or whose model does not follow the raw angle closer
    (closer_on_raw) than every significant candidate of the eight's in the round and, where
    it leads the eight's best, than their best two together (`fit_pair`: the second fitted
    beside the first's model), or, in a `later` round, does not beat `base` (beats_on_raw:
    a model so far at the noise is not added to by a stand-in)."""
    eight = [c for c in candidates if not gated(problem, c.name) and c.significant]
    eight_raw = {c.name: raw_deg(problem, c.fit.angle_deg) for c in eight}
    base_raw = [raw_deg(problem, base.angle_deg)] if later else []
    pair_raw: dict[tuple[str, str], float] = {}  # each pair of the eight fitted once
    out = []
    for c in candidates:
        if gated(problem, c.name):
            if not c.significant:
                continue
            own = raw_deg(problem, c.fit.angle_deg)
            rivals = [e for e in eight if not paired(c.name, e.name)]
            if not all(closer_on_raw(own, eight_raw[e.name]) for e in rivals):
                continue
            if not all(beats_on_raw(own, before, float(c.fit.sigma_deg)) for before in base_raw):
                continue  # the model so far at the noise leaves the raw angle nothing to show
            if len(rivals) >= 2 and c.delta_bic > rivals[0].delta_bic:
                # one physics the eight draw as two (a mounted weight: gravity and a cubic)
                pair = (rivals[0].name, rivals[1].name)
                if pair not in pair_raw:
                    pair_raw[pair] = raw_deg(problem, fit_pair(rivals[0].fit, rivals[1].name).fit.angle_deg)
                if not closer_on_raw(own, pair_raw[pair]):
                    continue
        out.append(c)
    return out


def friction_rival(problem: Problem, best: Candidate, candidates: list[Candidate], remaining: list[str],
                   fit_beside: Callable[[str], Candidate]) -> Candidate | None:
    """Where the round's best is the loop: dry friction's candidate when the loop does not
    beat it on the raw angle (a tie), else None. Dry friction is fitted (`fit_beside`) where
    the round did not fit it. Whether dry friction would be named itself does not enter:
    the raw angle alone says whether it draws the loop as well."""
    if best.name != LOOP or FRICTION not in remaining:
        return None
    friction = next((c for c in candidates if c.name == FRICTION), None) or fit_beside(FRICTION)
    noise_deg = float(best.fit.sigma_deg)
    if loop_beats_friction(raw_deg(problem, best.fit.angle_deg), raw_deg(problem, friction.fit.angle_deg),
                           noise_deg):
        return None
    return friction


def beside_a_tie(problem: Problem, candidates: list[Scored], kept_out: list[Screen], margin_bic: float,
                 fit_screened: Callable[[Screen], Scored]) -> list[Scored]:
    """Where the first round's two best of the eight tie (both significant, within
    `margin_bic`), the stand-ins the screen kept out (`kept_out`) fitted (`fit_screened`),
    those significant that follow the raw angle closer (closer_on_raw) than both tied effects
    and than every significant stand-in the screen let in: a tie says the eight have no name
    for the residual, and a stand-in whose screen fell below theirs at its shape's start may
    still draw it (a contact under PI steps, the finger bent one way, docs/results.md §12.57);
    one the screen let in may have the name already (a creep beside a lag and a dead time
    tied, where a loop fitted beside the tie out-gained it, further from the raw angle)."""
    eight = [c for c in candidates if not gated(problem, c.name) and c.significant]
    if len(eight) < 2 or eight[0].delta_bic - eight[1].delta_bic >= margin_bic:
        return []
    let_in = [c for c in candidates if gated(problem, c.name) and c.significant]
    rivals_raw = [raw_deg(problem, c.fit.angle_deg) for c in [*eight[:2], *let_in]]
    out = []
    for s in kept_out:
        c = fit_screened(s)
        if c.significant and all(closer_on_raw(raw_deg(problem, c.fit.angle_deg), r) for r in rivals_raw):
            out.append(c)
    return out
