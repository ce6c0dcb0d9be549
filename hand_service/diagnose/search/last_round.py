"""The last round again, every effect its screen left out fitted beside the picks.

After the first round the forward selection fits only the screen's strongest few, and of
those only what the screen's linear step predicts to gain on the innovations
(forward_selection.LATER_TOP, LATER_WHITE_BIC): every simulation there carries the picks.
The step is taken at the effect's start, from a model that already mimics part of it, and
can rank a real third effect out: a dead time beside a quadratic damping and dry friction
on steps was never fitted beside the two (the round fitted a dead zone instead, and the
search stopped), while fitted there it gains ΔBIC 449 with a held-out z of 7.8.

So where the selection stopped with two picks or more, room for one more, nothing carried
(a tie's round is not the picks'), and the picks' innovations still structured or following
the command (set_search.leaves_structure), each of the eight the last round did not fit is
fitted beside the picks, as a later round fits (`beside`, lazy). The best is added only as
the forward selection would accept it: it passes the gate beside the picks
(`Candidate.significant`: ΔBIC, held-out z, determined, not at a bound; the second quarter
asked as for any round's best, `second_look`), no other of the round is significant within
the naming margin unless the two together are, and the set holds across the postures
(set_search.holds). The effects that stand in for others (admission.gated) stay behind the
screen. The set goes on through the same checks as any other (the set's members, the
posture and outside-library checks, the raw-signal gate in the engine).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

from hand_service.diagnose.model.problem import Problem
from hand_service.diagnose.search import set_search
from hand_service.diagnose.search.admission import gated
from hand_service.diagnose.search.forward_selection import (
    MAX_EFFECTS,
    Candidate,
    Progress,
    Round,
    Selection,
    beside,
    second_look,
    tied,
)
from hand_service.diagnose.workers import ordered_map


@dataclass(frozen=True)
class Added:
    selection: Selection
    picks: tuple[str, ...]  # what the forward selection accepted
    added: Candidate  # fitted beside them, past its screen

    def sentence(self) -> str:
        picks = " and ".join(self.picks)
        return (f"the screen beside {picks} left {self.added.name} out of the last round; fitted beside "
                f"them it gains ΔBIC {self.added.delta_bic:.0f} (held-out z {self.added.z_heldout:.1f}) and "
                "is significant beside them, so it is added to the set (the checks that follow decide what "
                "is named)")


def left_out(problem: Problem, selection: Selection, names: list[str]) -> list[str]:
    """The effects of `names` not picked, not fitted beside the picks' model, and not gated."""
    final = selection.final
    picked = {c.name for c in selection.accepted}
    fitted = {c.name for r in selection.rounds if r.base is final for c in r.candidates}
    return [name for name in names if name not in picked | fitted and not gated(problem, name)]


def search(problem: Problem, selection: Selection, names: list[str],
           progress: Progress | None = None) -> Added | None:
    """The selection with one effect its last round's screen left out added (the module's
    docstring), or None."""
    if (not 2 <= len(selection.accepted) < MAX_EFFECTS or selection.carried or selection.final is None
            or not selection.rounds):
        return None
    final = selection.final
    others = left_out(problem, selection, names)
    if not others or not set_search.leaves_structure(problem, final):
        return None
    picks = tuple(c.name for c in selection.accepted)
    if progress:
        progress(f"fitting {', '.join(others)} beside {' and '.join(picks)} "
                 "(left out by the last round's screen)")
    candidates = sorted(ordered_map(lambda name: beside(problem, final, name, lazy=True), others),
                        key=lambda c: -c.delta_bic)
    round_ = Round(final, candidates)
    second_look(problem, round_)
    best = round_.best()
    if best is None or not best.significant:
        return None
    runner = round_.candidates[1] if len(round_.candidates) > 1 else None
    if tied(best, runner, lambda fit, name: beside(problem, fit, name)):
        return None  # two names for one signature: the forward selection's tie, not a third effect
    members = [*selection.accepted, best]
    if not set_search.holds(problem, members):
        return None
    return Added(replace(selection, rounds=[*selection.rounds, round_], accepted=members, final=best.fit),
                 picks, best)
