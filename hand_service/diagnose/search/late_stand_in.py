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
"""

from __future__ import annotations

import dataclasses

from hand_service.diagnose.fitting.output_error import Fit
from hand_service.diagnose.model.problem import Problem
from hand_service.diagnose.search.admission import gated
from hand_service.diagnose.search.forward_selection import Progress, Selection, select


def late_stand_in(problem: Problem, selection: Selection) -> str | None:
    """The screened effect accepted after the first pick with more ΔBIC than it, or None."""
    if len(selection.accepted) < 2:
        return None
    first = selection.accepted[0]
    late = [c for c in selection.accepted[1:] if gated(problem, c.name) and c.delta_bic > first.delta_bic]
    return max(late, key=lambda c: c.delta_bic).name if late else None


def select_screened(problem: Problem, refit: Fit, names: list[str],
                    progress: Progress | None = None) -> Selection:
    """forward_selection.select, run again with a late stand-in admitted from the first round."""
    selection = select(problem, refit, names, progress)
    name = late_stand_in(problem, selection)
    if name is None:
        return selection
    if progress:
        progress(f"{name} was screened out of the first round but gains more than "
                 f"{selection.accepted[0].name} did: the search again with it fitted from there")
    return select(dataclasses.replace(problem, asked=problem.asked | {name}), refit, names, progress)
