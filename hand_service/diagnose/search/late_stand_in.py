"""A stand-in the screen kept out of the first round, accepted in a later one with more
evidence than the first pick had: the selection again, with it fitted from the first round.

The screen sees an effect's size at its shape's start only (search/admission.py): a
contact whose onset lies away from that start's can screen below a cubic spring, stay out
of the first round, and then, beside the spring picked there, gain ten times the spring's
ΔBIC once its onset is fitted (docs/results.md §12.52). The first pick was chosen against
a field that lacked it, so it is not judged beside it: where a screened effect accepted
after the first round gains more ΔBIC over the model before it than the first pick gained
over the plain refit, the selection runs again with that effect admitted whatever its
screen (Problem.asked), and the rounds decide between them as for any two effects.

The same holds where such an effect, after the first round, passed every test but carrying
itself (forward_selection.carries_itself): a contact's spring refitted without its damper
is judged beside the model so far, and beside a cubic spring that took the spring's share
the spring alone adds nothing, while the truth's Hunt-Crossley contact, its damping scaled
by the depth, gained ΔBIC ten times the spring's beside it (docs/results.md §12.60). The
first round is where its spring is judged against the plain model; since that selection
settles only whether the stand-in carries itself there, it is kept only where it names it,
else the first selection stands.
"""

from __future__ import annotations

import dataclasses

from hand_service.diagnose.fitting.output_error import Fit
from hand_service.diagnose.model.problem import Problem
from hand_service.diagnose.search.admission import gated
from hand_service.diagnose.search.forward_selection import (
    SIGNIFICANT_BIC,
    Candidate,
    Progress,
    Selection,
    select,
)


def but_for_its_core(candidate: Candidate) -> bool:
    """Significant (Candidate.significant) in everything but carrying itself."""
    return (candidate.delta_bic > SIGNIFICANT_BIC and candidate.predicts and not candidate.at_bound
            and candidate.determined and not candidate.carries)


def late_stand_in(problem: Problem, selection: Selection) -> str | None:
    """The screened effect accepted after the first pick with more ΔBIC than it, or kept out
    of a round after the first only for not carrying itself (but_for_its_core) with more
    ΔBIC than it: the strongest such, or None."""
    if not selection.accepted:
        return None
    first = selection.accepted[0]
    late = [c for c in selection.accepted[1:] if gated(problem, c.name) and c.delta_bic > first.delta_bic]
    late += [c for round_ in selection.rounds[1:] for c in round_.uncarried
             if gated(problem, c.name) and c.delta_bic > first.delta_bic and but_for_its_core(c)]
    return max(late, key=lambda c: c.delta_bic).name if late else None


def select_screened(problem: Problem, refit: Fit, names: list[str],
                    progress: Progress | None = None) -> Selection:
    """forward_selection.select, run again with a late stand-in admitted from the first round
    (kept where the stand-in was accepted in the first selection, or is in the second)."""
    selection = select(problem, refit, names, progress)
    name = late_stand_in(problem, selection)
    if name is None:
        return selection
    if progress:
        progress(f"{name} was screened out of the first round but gains more than "
                 f"{selection.accepted[0].name} did: the search again with it fitted from there")
    again = select(dataclasses.replace(problem, asked=problem.asked | {name}), refit, names, progress)
    accepted = {c.name for c in selection.accepted}
    return again if name in accepted or name in {c.name for c in again.accepted} else selection
