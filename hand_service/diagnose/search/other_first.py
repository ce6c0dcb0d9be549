"""Other first picks: the forward selection again from the first round's other strong effects,
the set that explains the recording best kept.

The forward selection is a path: its first pick decides what is fitted after it. Two effects
missing at once can make a third look strongest alone, and the path it opens never fits the
true pair: a stiff finger with gravity and a pressure dead zone, where a cubic spring was
picked first (ΔBIC 1 104 against gravity's 994); beside the spring the dead zone did not
predict the held-out data and the search stopped, while gravity and the dead zone together
gain ΔBIC 1 769. Or nothing passes alone (a dead zone gained ΔBIC 128 in the fit and did not
predict), while beside it a cubic spring does and the two together gain 313.

So the strongest first-round effect that gained in the fit (ΔBIC over SIGNIFICANT_BIC) and is
not on the path already (OTHER_TOP of them) is taken as the first pick and the forward
selection runs on from it, by its own rules. On the truth's combinations every set found so
came from that first one, and each further path costs as much again. A path's set is compared with the
first path's by the ΔBIC of its final fit over the plain refit (every member, a tie's
carried one included, each paying its penalty), and replaces it only where it gains more by
the naming margin (NAME_MARGIN_BIC) and

- every member earns its place: refitted without it, the others kept, it passes the forward
  selection's own gate beside them (`Candidate.significant`), the path's first pick too,
  which was not judged beside the others;
- the set, as one effect would, beats the plain refit (set_search.beats: ΔBIC and the
  held-out data);
- it holds across the recording's postures (set_search.withdrawn names none).

The set found goes on through the same checks as any other (the posture and outside-library
checks, the raw-signal gate in the engine).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from hand_service.diagnose.fitting.output_error import Fit
from hand_service.diagnose.model.problem import Problem
from hand_service.diagnose.search import set_search
from hand_service.diagnose.search.admission import closer_on_raw, gated, raw_deg
from hand_service.diagnose.search.forward_selection import (
    NAME_MARGIN_BIC,
    SIGNIFICANT_BIC,
    Progress,
    Selection,
    beside,
    evidence,
    select,
)
from hand_service.diagnose.search.set_members import without

OTHER_TOP = 1  # the first round's other effects that gained in the fit, strongest first, tried first


@dataclass(frozen=True)
class OtherFirst:
    selection: Selection
    first: tuple[str, ...]  # what the first path named
    gain_bic: float  # the set's ΔBIC over the plain refit
    first_gain_bic: float  # the first path's

    def sentence(self) -> str:
        names = " and ".join(c.name for c in self.selection.accepted)
        before = " and ".join(self.first) or "nothing"
        return (f"the forward selection picked {before}; started from {self.selection.accepted[0].name} "
                f"instead, it finds {names}, which together explain the recording better (ΔBIC "
                f"{self.gain_bic:.0f} over the plain model, against {self.first_gain_bic:.0f}), each "
                "significant beside the others, so that set is kept (the checks that follow decide what "
                "is named)")


def set_bic(problem: Problem, refit: Fit, final: Fit | None) -> float:
    """The ΔBIC of a path's final fit over the plain refit (0 for no effect)."""
    if final is None or final is refit:
        return 0.0
    return evidence(problem, refit, problem.innovations(refit.angle_deg), final)[0]


def earns_places(problem: Problem, selection: Selection) -> bool:
    """Every accepted effect but the last (picked beside all the others) passes the gate
    refitted beside the others, and none is pinned at a plausible bound in the set's own
    fit (the gate's `at_bound`: stretched to mimic something else, it is no evidence for
    itself, wherever its refit beside the others lands)."""
    final = selection.final
    assert final is not None
    if any(c.at_bound_in(final) for c in selection.accepted):
        return False
    return all(beside(problem, without(problem, final, c.name), c.name, lazy=True).significant
               for c in selection.accepted[:-1])


def stand_ins_closer(problem: Problem, first: Selection, path: Selection) -> bool:
    """A path that names a stand-in (admission.gated) the first path does not follows the raw
    angle closer than the first path's model by the raw angle's tie share (admission.kept's
    rule for a round): its gain on the innovations alone is not yet the physics."""
    named = {c.name for c in first.accepted}
    if first.final is None or path.final is None or not any(
            gated(problem, c.name) and c.name not in named for c in path.accepted):
        return True
    return closer_on_raw(set_raw_deg(problem, path.final), set_raw_deg(problem, first.final))


def set_raw_deg(problem: Problem, final: Fit) -> float:
    """A path's final fit's RMS error on the raw angle (admission.raw_deg)."""
    return raw_deg(problem, final.angle_deg)


def search(problem: Problem, refit: Fit, selection: Selection, names: list[str],
           progress: Progress | None = None) -> OtherFirst | None:
    """The best path from another first pick that replaces the first path's set (the module's
    docstring), or None."""
    if not selection.rounds:
        return None
    on_path = {c.name for c in (*selection.accepted, *selection.carried)}
    if selection.ambiguous is not None:
        on_path |= {c.name for c in selection.ambiguous}
    others = [c for c in selection.rounds[0].candidates
              if c.delta_bic > SIGNIFICANT_BIC and c.name not in on_path][:OTHER_TOP]
    if not others:
        return None
    first_bic = set_bic(problem, refit, selection.final)
    best: tuple[float, Selection] | None = None
    for other in others:
        if progress:
            progress(f"the forward selection again, started from {other.name}")
        path = select(problem, refit, names, progress, first=other)
        gain = set_bic(problem, refit, path.final)
        if gain <= first_bic + NAME_MARGIN_BIC or (best is not None and gain <= best[0]):
            continue
        if len(path.accepted) < 2 or not set_search.beats(problem, refit, path.accepted):
            continue
        if not stand_ins_closer(problem, selection, path):  # before the refits below: one comparison
            continue
        if set_search.withdrawn(problem, path) or not earns_places(problem, path):
            continue
        best = (gain, dataclasses.replace(path, rounds=[selection.rounds[0], *path.rounds[1:]]))
    if best is None:
        return None
    return OtherFirst(best[1], tuple(c.name for c in selection.accepted), best[0], first_bic)
