"""The set search after a withdrawn pick (search/set_search.py): its logic on stand-ins for
the fits (cheap), and the measured case on the truth generator (thorough)."""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import pytest

from hand_service.diagnose.search import set_search
from hand_service.diagnose.search.forward_selection import Round, Selection


@dataclass
class FakeCandidate:
    name: str
    fit: str  # the effects fitted, joined by "+"
    significant: bool
    delta_bic: float
    params: list = field(default_factory=list)


@dataclass
class FakeScreen:
    name: str
    predicted_bic: float


# (the fit added to, the effect added): significant beside it? Gravity and the asymmetric
# spring each lose alone beside dry friction and gain only beside each other.
GAINS = {("refit+coulomb", "gravity"): False, ("refit+coulomb", "asymmetric_stiffness"): False,
         ("refit+coulomb+gravity", "asymmetric_stiffness"): True,
         ("refit+coulomb+asymmetric_stiffness", "gravity"): True}
SCREEN = {"gravity": 50.0, "quadratic_damping": 20.0, "valve_lag": 10.0, "asymmetric_stiffness": -5.0,
          "dead_time": -8.0, "cubic_stiffness": -10.0}


def selection_with(picks: list[str]) -> Selection:
    accepted, fit = [], "refit"
    for name in picks:
        fit = f"{fit}+{name}"
        accepted.append(FakeCandidate(name, fit, True, 100.0))
    others = [FakeCandidate(n, f"refit+{n}", False, 10.0) for n in SCREEN if n not in picks]
    round1 = [accepted[0], *others]
    later = [Round(a.fit, [b]) for a, b in itertools.pairwise(accepted)]
    return Selection(rounds=[Round("refit", round1), *later], accepted=accepted, final=fit)


def use_stand_ins(monkeypatch, gains: dict[tuple[str, str], bool], screened: dict[str, float]) -> list:
    """set_search's fits replaced by `gains` (significant beside that fit?) and its screen
    by `screened`; the fits asked for, in order."""
    calls: list[tuple[str, str]] = []

    def add(problem, base, name):
        calls.append((base, name))
        gained = gains.get((base, name), False)
        return FakeCandidate(name, f"{base}+{name}", gained, 400.0 if gained else -20.0)

    monkeypatch.setattr(set_search, "screen", lambda problem, base, name: FakeScreen(name, screened[name]))
    monkeypatch.setattr(set_search, "add", add)
    monkeypatch.setattr(set_search, "holds", lambda problem, members: True)
    return calls


@pytest.fixture
def stand_ins(monkeypatch):
    return use_stand_ins(monkeypatch, GAINS, SCREEN)


def test_a_withdrawn_later_pick_gives_way_to_the_pair_it_crowded_out(stand_ins, monkeypatch):
    monkeypatch.setattr(set_search, "withdrawn", lambda problem, selection: ["cubic_stiffness"])
    selection = selection_with(["coulomb", "cubic_stiffness", "asymmetric_stiffness"])
    found = set_search.search(None, selection)
    assert found is not None
    assert [c.name for c in found.selection.accepted] == ["coulomb", "asymmetric_stiffness", "gravity"]
    assert found.selection.final in ("refit+coulomb+gravity+asymmetric_stiffness",
                                     "refit+coulomb+asymmetric_stiffness+gravity")
    assert "cubic_stiffness" not in {name for _, name in stand_ins}  # the withdrawn pick is not refitted
    assert "cubic_stiffness was picked" in found.sentence()
    # every member found is in a round, as the report's evidence for it needs
    assert all(any(c in r.candidates for r in found.selection.rounds) for c in found.selection.accepted)


def test_a_pair_is_taken_only_where_each_member_gains_beside_the_other(stand_ins, monkeypatch):
    monkeypatch.setattr(set_search, "withdrawn", lambda problem, selection: ["cubic_stiffness"])
    GAINS_ONE_WAY = {**GAINS, ("refit+coulomb+asymmetric_stiffness", "gravity"): False}
    monkeypatch.setattr(set_search, "GAINS", GAINS_ONE_WAY, raising=False)

    def add(problem, base, name):
        gains = GAINS_ONE_WAY.get((base, name), False)
        return FakeCandidate(name, f"{base}+{name}", gains, 400.0 if gains else -20.0)

    monkeypatch.setattr(set_search, "add", add)
    selection = selection_with(["coulomb", "cubic_stiffness", "asymmetric_stiffness"])
    assert set_search.search(None, selection) is None


def test_nothing_is_searched_where_every_pick_holds_and_leaves_no_structure(stand_ins, monkeypatch):
    monkeypatch.setattr(set_search, "withdrawn", lambda problem, selection: [])
    monkeypatch.setattr(set_search, "leaves_structure", lambda problem, final: False)
    assert set_search.search(None, selection_with(["coulomb"])) is None
    assert stand_ins == []


def test_a_pick_that_leaves_structure_is_kept_and_pairs_are_fitted_beside_it(stand_ins, monkeypatch):
    monkeypatch.setattr(set_search, "withdrawn", lambda problem, selection: [])
    monkeypatch.setattr(set_search, "leaves_structure", lambda problem, final: True)
    found = set_search.search(None, selection_with(["coulomb"]))
    assert found is not None
    assert [c.name for c in found.selection.accepted] == ["coulomb", "gravity", "asymmetric_stiffness"]
    assert all(base.startswith("refit+coulomb") for base, _ in stand_ins)  # the pick stays in every fit
    assert found.sentence().startswith("with coulomb alone a structured residual is left")


def test_no_pair_is_sought_where_a_pair_would_pass_the_most_effects(stand_ins, monkeypatch):
    monkeypatch.setattr(set_search, "withdrawn", lambda problem, selection: [])
    monkeypatch.setattr(set_search, "leaves_structure", lambda problem, final: True)
    assert set_search.search(None, selection_with(["coulomb", "quadratic_damping"])) is None
    assert stand_ins == []


def test_a_set_failing_the_posture_check_is_not_taken(stand_ins, monkeypatch):
    monkeypatch.setattr(set_search, "withdrawn", lambda problem, selection: ["cubic_stiffness"])
    monkeypatch.setattr(set_search, "holds", lambda problem, members: False)
    selection = selection_with(["coulomb", "cubic_stiffness", "asymmetric_stiffness"])
    assert set_search.search(None, selection) is None


@pytest.mark.thorough
def test_friction_gravity_and_an_asymmetric_spring_on_steps(tmp_path):
    """The measured case: the cubic spring picked second fails the posture check; the set
    search finds the truth's three, and each explains more of the raw angle than the
    structure the truth's static friction peak leaves: all three are named."""
    from tests.diagnose.truth import combinations

    effects = ("coulomb_friction", "gravity", "asymmetric_stiffness")
    row = combinations.run(effects, "steps", 0, tmp_path)
    assert row["observable"]
    assert "cubic_stiffness" not in row["named"] + row["partial"]
    assert set(effects) <= set(row["named"])
