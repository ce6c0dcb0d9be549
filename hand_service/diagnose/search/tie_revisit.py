"""A tie asked again once the rest of the set is in the model.

In the first round two effects may explain the residual about equally well (a valve lag
and a dead time on a slow finger); the forward selection carries the better one in the
model, unnamed, and looks for what else is missing (forward_selection.py). The tie was
judged on a residual that still held the other effects, which can blur the two
signatures together: with the clear second effect fitted, the recording may tell them
apart. So the two are fitted again, each in the carried one's place beside everything
accepted since, and one is named only when it now explains the residual better than the
other by the naming margin (NAME_MARGIN_BIC) and passes the forward selection's own gate
beside the others (`Candidate.significant`: ΔBIC, held-out z, determined, not at a
bound); otherwise the tie stands as it was. The set goes on through the same checks as
any other (the posture check, the outside-library checks, the raw-signal gate).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from hand_service.diagnose.model.problem import Problem
from hand_service.diagnose.search.forward_selection import (
    NAME_MARGIN_BIC,
    Progress,
    Round,
    Selection,
    beside,
)
from hand_service.diagnose.search.set_members import without
from hand_service.diagnose.workers import ordered_map


@dataclass(frozen=True)
class Resolved:
    selection: Selection
    named: str  # the one of the tie now named
    other: str
    margin_bic: float  # its ΔBIC over the other, each beside the set

    def sentence(self) -> str:
        return (f"{self.named} and {self.other} could not be told apart at first; with the effects found "
                f"since in the model, {self.named} explains the residual better (ΔBIC {self.margin_bic:.0f} "
                f"over {self.other}, each fitted beside them) and is significant beside them, so it is kept "
                "(the checks that follow decide what is named)")


def revisit(problem: Problem, selection: Selection, progress: Progress | None = None) -> Resolved | None:
    """The tie resolved beside the effects accepted after it, or None (no tie carried, nothing
    accepted beside it, or still a tie)."""
    if selection.ambiguous is None or not selection.carried or not selection.accepted:
        return None
    if selection.final is None:
        return None
    carried = selection.carried[0]
    first, second = selection.ambiguous
    other = second.name if carried.name == first.name else first.name
    if progress:
        progress(f"{carried.name} or {other}? fitting each beside "
                 f"{' and '.join(c.name for c in selection.accepted)}")
    rest = without(problem, selection.final, carried.name)
    candidates = sorted(ordered_map(lambda name: beside(problem, rest, name), (carried.name, other)),
                        key=lambda c: -c.delta_bic)
    best, runner = candidates
    margin = best.delta_bic - runner.delta_bic  # both against the same model: the set without either
    if margin < NAME_MARGIN_BIC or not best.significant:
        return None
    resolved = replace(selection, rounds=[*selection.rounds, Round(rest, candidates)],
                       accepted=[*selection.accepted, best], final=best.fit, ambiguous=None, carried=[])
    return Resolved(resolved, best.name, runner.name, margin)
