"""The forward selection's path revised after it ends, in order: sets where the posture check
withdraws a first pick (set_search.py), a first-round tie told apart beside the effects found
since (tie_revisit.py), a third effect the last round's screen left out (last_round.py), the
path from another first pick where it explains more (other_first.py), and a stand-in named
beside others that the library's own effect matches in its place (stand_in_place.py). Each
revision says what it changed in a sentence for the report."""

from __future__ import annotations

from hand_service.diagnose.fitting.output_error import Fit
from hand_service.diagnose.model.problem import Problem
from hand_service.diagnose.search import last_round, other_first, set_search, stand_in_place, tie_revisit
from hand_service.diagnose.search.forward_selection import Progress, Selection


def revise(problem: Problem, refit: Fit, selection: Selection, names: list[str], lost: bool,
           progress: Progress | None = None) -> tuple[Selection, list[str]]:
    """The selection after the five revisions, and their sentences. `lost`: the plain model
    cannot follow the recording (nothing was searched; no other path either)."""
    sentences: list[str] = []
    if (found_set := set_search.search(problem, selection, progress)) is not None:
        sentences.append(found_set.sentence())
        selection = found_set.selection
    if (tie := tie_revisit.revisit(problem, selection, progress)) is not None:
        sentences.append(tie.sentence())
        selection = tie.selection
    if (added := last_round.search(problem, selection, names, progress)) is not None:
        sentences.append(added.sentence())
        selection = added.selection
    if not lost and (other := other_first.search(problem, refit, selection, names, progress)) is not None:
        sentences.append(other.sentence())
        selection = other.selection
    if (placed := stand_in_place.revisit(problem, selection, names, progress)) is not None:
        sentences.append(placed.sentence())
        selection = placed.selection
    return selection, sentences
