"""A stand-in named beside other effects, asked again in the set's own company.

A stand-in the screen lets in (admission.gated: a contact, a material's loop, a
pressure-stiffened spring, creep) stays in its round only where its model follows the raw
angle closer than the round's significant fits of the eight (admission.kept). Where another
effect is missing too, those fits lack it, and the eight's own form of the stand-in's
physics may fail the gate alone: a valve lag and a cubic spring missing on a multisine, the
spring alone did not predict the held-out data, the stiffening chamber did and was kept, the
lag was found beside it, and the pair followed the recording to its noise, graded
`complete`, for a spring the library draws itself.

So once the path is revised, each gated stand-in accepted beside other effects is asked
again in their company: the set is refitted without it, and each of the library's effects
that are not stand-ins and not in the set is fitted in its place beside the rest
(forward_selection.beside, its other starts only where the first gains). Where one passes
the forward selection's gate (`Candidate.significant`) and the set with the stand-in does
not follow the raw angle closer than the set with it by the raw angle's tie share
(admission.closer_on_raw, as `kept` asks of a round), the stand-in gives its place to the
closest such one. Where none does, and the set still has room (forward_selection.MAX_EFFECTS),
the two strongest of them that pass the gate are asked together, the second fitted beside
the first: one physics the eight draw as two (a weight mounted at an angle is gravity and a
cubic spring, `kept`'s pair), which the stand-in draws as one; the pair takes its place
where it passes the gate and the stand-in's set is not closer by the tie share. The set goes
on through the same checks as any other.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import partial

from hand_service.config import effects as fx
from hand_service.diagnose.fitting.raw_error import TIE_SHARE
from hand_service.diagnose.model.problem import Problem
from hand_service.diagnose.search.admission import closer_on_raw, gated, raw_deg
from hand_service.diagnose.search.forward_selection import MAX_EFFECTS, Progress, Round, Selection, beside
from hand_service.diagnose.search.set_members import without
from hand_service.diagnose.workers import ordered_map


@dataclass(frozen=True)
class Replaced:
    selection: Selection
    stand_in: str
    drawn_by: tuple[str, ...]  # the library's effect, or two, that drew the raw angle as closely
    named: tuple[str, ...]  # those of them that pass the gate: now in its place
    beside: tuple[str, ...]  # the set's other effects
    stand_in_raw_deg: float  # the set's RMS error on the raw angle with the stand-in
    drawn_raw_deg: float  # and with drawn_by in its place

    def sentence(self) -> str:
        drawn = " and ".join(self.drawn_by)
        named = " and ".join(self.named)
        head = (f"{self.stand_in} was named beside {' and '.join(self.beside)}; fitted in its place beside "
                f"them, {drawn} {'together follow' if len(self.drawn_by) > 1 else 'follows'} the raw angle "
                f"within {100 * TIE_SHARE:.0f} % of it or closer ({self.drawn_raw_deg:.3g} deg RMS against "
                f"{self.stand_in_raw_deg:.3g})")
        after = "(the checks that follow decide what is named)"
        if self.named == self.drawn_by:
            both = len(self.named) > 1
            return (f"{head} and {'pass' if both else 'passes'} every gate, so {named} "
                    f"{'are' if both else 'is'} kept in its place {after}")
        left = " and ".join(n for n in self.drawn_by if n not in self.named)
        return (f"{head}, one physics the library draws as two; {left} does not pass the gate beside "
                f"{named}, so {named} alone is kept in its place {after}")


def revisit(problem: Problem, selection: Selection, names: list[str],
            progress: Progress | None = None) -> Replaced | None:
    """The set with its first stand-in that does not hold in its company replaced, or None.
    `names`: the effects searched."""
    final = selection.final
    if final is None or len(selection.accepted) < 2:
        return None
    taken = {c.name for c in (*selection.accepted, *selection.carried)}
    library = [n for n in names if n not in taken and not fx.BY_NAME[n].admitted_by_screen]
    own_deg = raw_deg(problem, final.angle_deg)
    for stand_in in (c for c in selection.accepted if gated(problem, c.name)):
        others = [c for c in selection.accepted if c is not stand_in]
        if progress:
            progress(f"{stand_in.name} beside {' and '.join(c.name for c in others)}: fitting "
                     f"{', '.join(library)} in its place")
        rest = without(problem, final, stand_in.name)
        candidates = sorted(ordered_map(partial(beside, problem, rest, lazy=True), library),
                            key=lambda c: -c.delta_bic)
        passing = [c for c in candidates if c.significant]
        rivals = [(r, c) for r, c in ((raw_deg(problem, c.fit.angle_deg), c) for c in passing)
                  if not closer_on_raw(own_deg, r)]
        rounds = [*selection.rounds, Round(rest, candidates)]
        if rivals:
            drawn_deg, named = min(rivals, key=lambda rc: rc[0])
            drawn = placed = [named]
        elif len(passing) >= 2 and len(others) + 2 <= MAX_EFFECTS:
            second = beside(problem, passing[0].fit, passing[1].name, lazy=True)
            drawn_deg = raw_deg(problem, second.fit.angle_deg)
            if closer_on_raw(own_deg, drawn_deg):
                continue
            drawn = [passing[0], second]
            placed = drawn if second.significant else [passing[0]]
            if second.significant:
                rounds.append(Round(passing[0].fit, [second]))
        else:
            continue
        revised = replace(selection, rounds=rounds, accepted=[*others, *placed], final=placed[-1].fit)
        return Replaced(revised, stand_in.name, tuple(c.name for c in drawn), tuple(c.name for c in placed),
                        tuple(c.name for c in others), own_deg, drawn_deg)
    return None
