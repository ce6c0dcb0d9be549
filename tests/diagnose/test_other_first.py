"""The forward selection again from other first picks (search/other_first.py): its logic on
stand-ins for the fits (cheap), and the measured case on the truth generator (thorough)."""

from __future__ import annotations

from dataclasses import dataclass

import pytest

from hand_service.diagnose.search import other_first
from hand_service.diagnose.search.forward_selection import Round, Selection


@dataclass
class FakeCandidate:
    name: str
    delta_bic: float
    fit: str = ""


def first_path(accepted: list[str], round1: dict[str, float], carried: str = "") -> Selection:
    """A first path that accepted `accepted` (carried `carried`), its first round `round1`."""
    candidates = [FakeCandidate(n, bic, f"refit+{n}") for n, bic in round1.items()]
    picks = [c for c in candidates if c.name in accepted]
    selection = Selection(rounds=[Round("refit", candidates)], accepted=picks,
                          final="+".join(["refit", *accepted, *([carried] if carried else [])]))
    if carried:
        selection.carried = [next(c for c in candidates if c.name == carried)]
    return selection


def use_stand_ins(monkeypatch, paths: dict[str, tuple[list[str], float]], first_bic: float,
                  earns: bool = True, holds: bool = True) -> list[str]:
    """select(first=X) gives `paths[X]` (its accepted names and its set's ΔBIC over the refit),
    the first path's set `first_bic`; the names the selection was started from, in order."""
    started: list[str] = []
    gains = {"first": first_bic}

    def select(problem, refit, names, progress=None, first=None):
        started.append(first.name)
        accepted, gain = paths[first.name]
        final = "path:" + "+".join(accepted)
        gains[final] = gain
        return Selection(rounds=[Round("refit", [first]), Round(first.fit, [])],
                         accepted=[FakeCandidate(n, gain) for n in accepted], final=final)

    monkeypatch.setattr(other_first, "select", select)
    monkeypatch.setattr(other_first, "set_bic",
                        lambda problem, refit, final: gains.get(final, gains["first"]))
    monkeypatch.setattr(other_first.set_search, "beats", lambda problem, base, members: True)
    monkeypatch.setattr(other_first.set_search, "withdrawn",
                        lambda problem, selection: [] if holds else [selection.accepted[0].name])
    monkeypatch.setattr(other_first, "earns_places", lambda problem, selection: earns)
    return started


ROUND1 = {"cubic_stiffness": 1104.0, "gravity": 994.0, "valve_lag": 40.0, "dead_time": 5.0}


def test_a_path_from_another_first_pick_that_explains_more_replaces_the_first(monkeypatch):
    started = use_stand_ins(monkeypatch, {"gravity": (["gravity", "pressure_deadzone"], 1769.0),
                                          "valve_lag": (["valve_lag", "cubic_stiffness"], 1150.0)}, 1104.0)
    selection = first_path(["cubic_stiffness"], ROUND1)
    found = other_first.search(None, "refit", selection, list(ROUND1))
    assert started == ["gravity"]  # the strongest that gained in the fit, off the path
    assert found is not None
    assert [c.name for c in found.selection.accepted] == ["gravity", "pressure_deadzone"]
    assert found.selection.rounds[0] is selection.rounds[0]  # the evidence table stays the first round's
    assert "picked cubic_stiffness; started from gravity" in found.sentence()


def test_further_paths_are_tried_in_the_first_round_order_and_the_best_kept(monkeypatch):
    monkeypatch.setattr(other_first, "OTHER_TOP", 2)
    started = use_stand_ins(monkeypatch, {"gravity": (["gravity", "pressure_deadzone"], 1200.0),
                                          "valve_lag": (["valve_lag", "cubic_stiffness"], 1300.0)}, 1104.0)
    found = other_first.search(None, "refit", first_path(["cubic_stiffness"], ROUND1), list(ROUND1))
    assert started == ["gravity", "valve_lag"]
    assert found is not None
    assert [c.name for c in found.selection.accepted] == ["valve_lag", "cubic_stiffness"]


def test_a_path_within_the_naming_margin_does_not_replace_the_first(monkeypatch):
    use_stand_ins(monkeypatch, {"gravity": (["gravity", "cubic_stiffness"], 1110.0)}, 1104.0)
    assert other_first.search(None, "refit", first_path(["cubic_stiffness"], ROUND1), list(ROUND1)) is None


@pytest.mark.parametrize("earns, holds", [(False, True), (True, False)])
def test_a_path_whose_member_does_not_earn_its_place_or_hold_is_not_taken(monkeypatch, earns, holds):
    use_stand_ins(monkeypatch, {"gravity": (["gravity", "pressure_deadzone"], 1769.0),
                                "valve_lag": (["valve_lag"], 40.0)}, 1104.0, earns=earns, holds=holds)
    assert other_first.search(None, "refit", first_path(["cubic_stiffness"], ROUND1), list(ROUND1)) is None


def test_a_single_effect_path_is_not_taken(monkeypatch):
    """One effect is the first round's to choose, by its own margin."""
    use_stand_ins(monkeypatch, {"gravity": (["gravity"], 1500.0), "valve_lag": (["valve_lag"], 40.0)}, 1104.0)
    assert other_first.search(None, "refit", first_path(["cubic_stiffness"], ROUND1), list(ROUND1)) is None


def test_the_path_and_a_tie_are_not_started_from_and_nothing_that_did_not_gain(monkeypatch):
    round1 = {"valve_lag": 900.0, "dead_time": 895.0, "gravity": 300.0, "cubic_stiffness": 9.0}
    started = use_stand_ins(monkeypatch, {"gravity": (["gravity", "valve_lag"], 950.0)}, 1000.0)
    selection = first_path([], round1, carried="valve_lag")
    selection.ambiguous = (selection.rounds[0].candidates[0], selection.rounds[0].candidates[1])
    assert other_first.search(None, "refit", selection, list(round1)) is None
    assert started == ["gravity"]


@pytest.mark.thorough
def test_gravity_and_a_dead_zone_behind_a_cubic_spring_picked_first(tmp_path):
    """The measured case: on a stiff finger (multisine, seed 0) a cubic spring is picked first
    and beside it the dead zone does not predict the held-out data; from gravity, the dead zone
    gains and the pair explains more than the spring: both are named, the spring is not."""
    from tests.diagnose.truth import combinations

    effects = ("gravity", "pressure_deadzone")
    row = combinations.run(effects, "multisine", 0, tmp_path)
    assert row["observable"]
    assert set(effects) <= set(row["named"])
    assert "cubic_stiffness" not in row["named"]
