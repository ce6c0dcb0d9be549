"""Sets after a withdrawn pick: when an effect the forward selection picked does not hold
across the recording's postures (posture_stability), the path it opened is closed, but the
effects it may have crowded out are not. Dry friction, gravity and an asymmetric spring on
steps: dry friction, then a cubic spring, then the asymmetric spring were picked; the cubic
failed the posture check, and the greedy path never fitted gravity and the asymmetric
spring together (neither gains alone beside dry friction; each gains ΔBIC 800 to 1 000
beside the other).

The effects accepted before the first withdrawn pick are kept; of the others, those picked
beside a withdrawn one first, then the screen's strongest on the kept model, SET_TOP in
all, are paired and fitted together, and the best pair that passes is extended by a third
while the set stays within MAX_EFFECTS. Each member of a pair must pass the forward
selection's own gate (`Candidate.significant`: ΔBIC, held-out z, determined, not at a
bound) fitted beside the other, a third beside the pair; the set must hold across the
postures, its first effect alone too. The set found goes on through the same checks as any
other (the posture check again, the outside-library checks, the raw-signal gate in the
engine).

Every fit here carries the picks (dry friction's simulations cost ten times a plain
finger's), so each is fitted as the forward selection's later rounds fit (`score`'s
`lazy`): from the screen's most promising start first, and from the others only where that
fit gains anything (ΔBIC above 0). An effect alone beside the picks is then, where the
forward selection fitted it beside them, that very fit (found again, fitting/output_error.fit).
"""

from __future__ import annotations

import dataclasses
import itertools
from dataclasses import dataclass

from hand_service.diagnose.fitting.output_error import Fit
from hand_service.diagnose.model.problem import Problem
from hand_service.diagnose.report.verdict import structure_left
from hand_service.diagnose.residual import stats
from hand_service.diagnose.search import posture_stability
from hand_service.diagnose.search.forward_selection import (
    MAX_EFFECTS,
    SIGNIFICANT_BIC,
    Candidate,
    Progress,
    Round,
    Selection,
    beside,
    evidence,
)
from hand_service.diagnose.search.screening import screen
from hand_service.diagnose.workers import ordered_map

SET_TOP = 4  # the first round's strongest effects (the withdrawn one aside) that are paired


@dataclass
class SetFound:
    selection: Selection
    withdrawn: list[str]  # the picks that did not hold across the postures ([]: the picks left structure)
    picked: list[str]  # what the forward selection accepted

    def sentence(self) -> str:
        names = " and ".join(c.name for c in self.selection.accepted)
        if not self.picked:
            return ("no effect alone passed every gate, and the plain model leaves a structured residual; "
                    f"{names} were fitted together, each significant beside the others and the set against "
                    "the plain model (the checks that follow decide what is named)")
        if not self.withdrawn:
            return (f"with {' and '.join(self.picked)} alone a structured residual is left; "
                    f"{names} were fitted together, each significant beside the others "
                    "(the checks that follow decide what is named)")
        gone = " and ".join(self.withdrawn)
        return (f"{gone} was picked but does not hold across the recording's postures; "
                f"without it, {names} were fitted together, each significant beside the others "
                "(the checks that follow decide what is named)")


def withdrawn(problem: Problem, selection: Selection) -> list[str]:
    """The accepted effects that fail the posture check: in the final fit beside the others,
    and the first fitted alone (its own round's fit). The engine would withdraw them and
    name at most the first of what is left ([] when every one holds)."""
    if not selection.accepted or selection.final is None:
        return []
    names = [c.name for c in selection.accepted]
    failed = [u.name for u in posture_stability.check(problem, selection.final, names)]
    if len(names) > 1 and posture_stability.first_alone_unstable(problem, selection):
        failed.append(names[0])
    return list(dict.fromkeys(failed))


def add(problem: Problem, base: Fit, name: str) -> Candidate:
    """`name` fitted beside `base`, from its other starts only where the most promising one
    gains (the module's docstring)."""
    return beside(problem, base, name, lazy=True)


def holds(problem: Problem, members: list[Candidate]) -> bool:
    """Every posture-dependent member holds in the set's fit, and the first alone too."""
    names = [c.name for c in members]
    return not posture_stability.check(problem, members[-1].fit, names) and not (
        posture_stability.check(problem, members[0].fit, [names[0]]))


def total_bic(members: list[Candidate]) -> float:
    return sum(c.delta_bic for c in members)


def leaves_structure(problem: Problem, final: Fit) -> bool:
    """The model's innovations are structured or still follow the command (the engine's
    structure-left test, report/verdict.py)."""
    mask = problem.fit_mask
    e = problem.innovations(final.angle_deg)[mask]
    lags = stats.whiteness_lags(problem.rate_hz)
    first_lag = 1 if problem.input_hold == "zoh" else 0
    return bool(structure_left(stats.ljung_box(e, lags),
                               stats.input_independence(e, problem.pressure_kpa[mask], lags, first_lag)))


def search(problem: Problem, selection: Selection, progress: Progress | None = None) -> SetFound | None:
    """The best set that passes every gate without the withdrawn picks: the effects accepted
    before the first of them, and two or three more from the round it was picked in. Where
    every pick holds but the picks leave structure (and room for more), the same beside all
    of them: two effects that each gain nothing alone beside the picks may gain together.
    None when no set passes, or nothing asks for one."""
    if not selection.rounds or selection.final is None or selection.carried:
        return None  # (a tie carried in the model: its round's base is not the picks')
    if not selection.accepted:
        return unpicked(problem, selection, progress)
    picked = [c.name for c in selection.accepted]
    gone = withdrawn(problem, selection)
    if not gone:
        if len(picked) + 2 > MAX_EFFECTS or not leaves_structure(problem, selection.final):
            return None
        return pairs(problem, selection, len(picked), [], progress)
    at = min(i for i, c in enumerate(selection.accepted) if c.name in gone)
    return pairs(problem, selection, at, gone, progress)


def unpicked(problem: Problem, selection: Selection, progress: Progress | None) -> SetFound | None:
    """Nothing accepted, though the first round's best gained in the fit (ΔBIC over
    SIGNIFICANT_BIC) and failed a later gate, and the plain model leaves structure: pairs
    from the plain refit, each pair taken only where it also beats the refit (`beats`). Two
    effects may each lose alone against a refit that mimics them both: a valve lag and a
    dead time on steps, where k, B and N fell 500 times to let the finger's inertia delay
    it, and either alone predicted the held-out data worse (z −6)."""
    first = selection.rounds[0].best()
    if first is None or first.delta_bic <= SIGNIFICANT_BIC or not leaves_structure(problem, selection.final):
        return None
    # the pool led by what gained in the fits, not by the screen: the screen's linear step
    # from a refit that mimics the effects ranks them below their stand-ins
    gained = [c.name for c in selection.rounds[0].candidates if c.delta_bic > SIGNIFICANT_BIC]
    return pairs(problem, selection, 0, [], progress, against_base=True, ranked=gained)


def beats(problem: Problem, base: Fit, members: list[Candidate]) -> bool:
    """The set's fit passes the forward selection's evidence gate against `base` as one
    effect would (ΔBIC over SIGNIFICANT_BIC, and the held-out data favour it)."""
    before = problem.innovations(base.angle_deg)
    bic, prior_gain, after = evidence(problem, base, before, members[-1].fit)
    held = problem.held_mask
    z = stats.heldout_z_innovations(before[held], after[held],
                                    problem.innovation_sigma(before, len(base.params)))
    whole = dataclasses.replace(members[-1], delta_bic=bic, z_heldout=z, prior_gain=prior_gain)
    return bool(bic > SIGNIFICANT_BIC and whole.predicts)


def pairs(problem: Problem, selection: Selection, at: int, gone: list[str],
          progress: Progress | None, against_base: bool = False,
          ranked: list[str] | None = None) -> SetFound | None:
    """The picks before `at` kept, the others (but `gone`) and the screen's strongest paired
    beside them, the best pair that passes extended by a third (`against_base`: each set
    must also beat the model it started from, `beats`; `ranked`: the pool's head, in place
    of the picks made beside a withdrawn one)."""
    prefix = selection.accepted[:at]
    base = prefix[-1].fit if prefix else selection.rounds[0].base
    taken = {c.name for c in prefix} | set(gone)
    names = [c.name for c in selection.rounds[0].candidates if c.name not in taken]
    screens = sorted(ordered_map(lambda name: screen(problem, base, name), names),
                     key=lambda s: -s.predicted_bic)
    after = [c.name for c in selection.accepted[at:] if c.name not in gone]  # picked beside a withdrawn one
    if ranked is not None:
        after = [name for name in ranked if name in names]
    pool = [*after, *[s.name for s in screens if s.name not in after]][:SET_TOP]
    sets: list[list[Candidate]] = []
    rounds: list[Round] = []
    # Every fit of a stage side by side (workers.ordered_map), the sets then taken in the
    # screen's order: the same sets as one pair at a time, on any number of threads.
    combos = list(itertools.combinations(pool, 2))  # the screen's order
    if progress and combos:
        why = f"{' and '.join(gone)} withdrawn" if gone else "structure left"
        progress(f"{why}: fitting {', '.join(f'{a} and {b}' for a, b in combos)} together")
    alone = dict(zip(pool, ordered_map(lambda name: add(problem, base, name), pool if combos else []),
                     strict=False))
    b_beside = ordered_map(lambda ab: add(problem, alone[ab[0]].fit, ab[1]), combos)
    each = [(a, b, b_beside_a) for (a, b), b_beside_a in zip(combos, b_beside, strict=True)
            if b_beside_a.significant]
    a_beside = ordered_map(lambda ab: add(problem, alone[ab[1]].fit, ab[0]), each)  # each earns its place

    def pair_passes(pair: list[Candidate]) -> bool:
        a_beside_b = pair[-2]
        return (a_beside_b.significant and (not against_base or beats(problem, base, pair))
                and holds(problem, pair))

    found = [[*prefix, a_beside_b, b_beside_a]
             for (_, _, b_beside_a), a_beside_b in zip(each, a_beside, strict=True)]
    for (a, b, b_beside_a), pair, passed in zip(each, found, ordered_map(pair_passes, found), strict=True):
        if passed:
            sets.append(pair)
            rounds += [Round(alone[b].fit, [pair[-2]]), Round(alone[a].fit, [b_beside_a])]
    if not sets:
        return None
    best = max(sets, key=total_bic)
    if len(best) < MAX_EFFECTS:
        others = [name for name in pool if name not in {c.name for c in best}]
        if progress and others:
            progress(f"adding {' or '.join(others)} to {' and '.join(c.name for c in best)}")
        thirds = ordered_map(lambda name: add(problem, best[-1].fit, name), others)

        def third_passes(third: Candidate) -> bool:
            return third.significant and holds(problem, [*best, third]) and (
                not against_base or beats(problem, base, [*best, third]))

        for third, passed in zip(thirds, ordered_map(third_passes, thirds), strict=True):
            if passed:
                sets.append([*best, third])
                rounds.append(Round(best[-1].fit, [third]))
    best = max(sets, key=total_bic)
    return SetFound(Selection(rounds=[*selection.rounds, *rounds], accepted=best, final=best[-1].fit), gone,
                    [c.name for c in selection.accepted])
