"""The last round again with what its screen left out (search/last_round.py): its logic on
stand-ins for the fits (cheap), and the measured case on the truth generator (thorough)."""

from __future__ import annotations

from dataclasses import dataclass

import pytest

from hand_service.diagnose.search import last_round
from hand_service.diagnose.search.forward_selection import Round, Selection

EIGHT = ["valve_lag", "dead_time", "coulomb_friction", "cubic_stiffness", "gravity", "asymmetric_stiffness",
         "quadratic_damping", "pressure_deadzone"]


@dataclass
class FakeCandidate:
    name: str
    fit: str  # the effects fitted, joined by "+"
    delta_bic: float
    significant: bool
    z_heldout: float = 5.0


def two_picks(last_fitted: tuple[str, ...] = ("pressure_deadzone",)) -> Selection:
    """quadratic damping, then dry friction accepted; the last round, beside both, fitted
    `last_fitted` only (none significant) and the selection stopped."""
    damping = FakeCandidate("quadratic_damping", "refit+quadratic_damping", 516.0, True)
    friction = FakeCandidate("coulomb_friction", "refit+quadratic_damping+coulomb_friction", 550.0, True)
    round1 = [damping, *[FakeCandidate(n, f"refit+{n}", -9.0, False) for n in EIGHT
                         if n not in ("quadratic_damping",)]]
    last = Round(friction.fit, [FakeCandidate(n, f"{friction.fit}+{n}", 3.0, False) for n in last_fitted])
    return Selection(rounds=[Round("refit", round1), Round(damping.fit, [friction]), last],
                     accepted=[damping, friction], final=friction.fit)


def use_stand_ins(monkeypatch, gains: dict[str, float], structure: bool = True, holds: bool = True,
                  pair_significant: bool = False) -> list[str]:
    """Each effect fitted beside the picks gains `gains[name]` (significant over 10); the
    names fitted, in order."""
    fitted: list[str] = []

    def beside(problem, base, name, lazy=False):
        if base.endswith("coulomb_friction"):
            fitted.append(name)
            gain = gains.get(name, -5.0)
            return FakeCandidate(name, f"{base}+{name}", gain, gain > 10.0)
        return FakeCandidate(name, f"{base}+{name}", 30.0 if pair_significant else 2.0, pair_significant)

    monkeypatch.setattr(last_round, "beside", beside)
    monkeypatch.setattr(last_round, "second_look", lambda problem, round_: None)
    monkeypatch.setattr(last_round.set_search, "leaves_structure", lambda problem, final: structure)
    monkeypatch.setattr(last_round.set_search, "holds", lambda problem, members: holds)
    return fitted


def test_a_third_effect_the_screen_left_out_is_fitted_beside_the_picks_and_added(monkeypatch):
    fitted = use_stand_ins(monkeypatch, {"dead_time": 449.0, "cubic_stiffness": 23.0})
    selection = two_picks()
    added = last_round.search(None, selection, EIGHT)
    assert added is not None
    assert [c.name for c in added.selection.accepted] == ["quadratic_damping", "coulomb_friction",
                                                          "dead_time"]
    assert added.selection.final == "refit+quadratic_damping+coulomb_friction+dead_time"
    assert added.selection.rounds[:3] == selection.rounds  # the search's rounds kept, this one after them
    assert added.selection.rounds[-1].base == selection.final
    # every one of the eight not picked and not fitted in the last round, and only those
    picked_or_fitted = {"quadratic_damping", "coulomb_friction", "pressure_deadzone"}
    assert sorted(fitted) == sorted(set(EIGHT) - picked_or_fitted)
    assert "left dead_time out of the last round" in added.sentence()
    assert "ΔBIC 449" in added.sentence()


def test_nothing_is_added_that_fails_the_gate_beside_the_picks(monkeypatch):
    use_stand_ins(monkeypatch, {"dead_time": 8.0, "gravity": 4.0})
    assert last_round.search(None, two_picks(), EIGHT) is None


def test_a_tie_within_the_naming_margin_is_not_a_third_effect(monkeypatch):
    use_stand_ins(monkeypatch, {"dead_time": 449.0, "valve_lag": 445.0})
    assert last_round.search(None, two_picks(), EIGHT) is None


def test_two_within_the_margin_that_are_significant_together_give_the_better(monkeypatch):
    use_stand_ins(monkeypatch, {"dead_time": 449.0, "valve_lag": 445.0}, pair_significant=True)
    added = last_round.search(None, two_picks(), EIGHT)
    assert added is not None and added.added.name == "dead_time"


def test_a_set_that_does_not_hold_across_the_postures_is_not_taken(monkeypatch):
    use_stand_ins(monkeypatch, {"dead_time": 449.0}, holds=False)
    assert last_round.search(None, two_picks(), EIGHT) is None


def test_no_fit_where_the_picks_leave_no_structure(monkeypatch):
    fitted = use_stand_ins(monkeypatch, {"dead_time": 449.0}, structure=False)
    assert last_round.search(None, two_picks(), EIGHT) is None
    assert fitted == []


@pytest.mark.parametrize("picks", [1, 3])
def test_only_two_picks_with_room_for_a_third_are_extended(monkeypatch, picks):
    fitted = use_stand_ins(monkeypatch, {"dead_time": 449.0})
    selection = two_picks()
    if picks == 1:
        selection.accepted = selection.accepted[:1]
    else:
        selection.accepted.append(FakeCandidate("gravity", selection.final + "+gravity", 40.0, True))
    assert last_round.search(None, selection, EIGHT) is None
    assert fitted == []


def test_a_carried_tie_is_left_to_its_own_revision(monkeypatch):
    fitted = use_stand_ins(monkeypatch, {"dead_time": 449.0})
    selection = two_picks()
    selection.carried = [selection.rounds[0].candidates[1]]
    assert last_round.search(None, selection, EIGHT) is None
    assert fitted == []


def test_stand_ins_stay_behind_the_screen(monkeypatch):
    fitted = use_stand_ins(monkeypatch, {"hysteresis": 900.0})
    monkeypatch.setattr(last_round, "gated", lambda problem, name: name == "hysteresis")
    assert last_round.search(None, two_picks(), [*EIGHT, "hysteresis"]) is None
    assert "hysteresis" not in fitted


@pytest.mark.thorough
def test_a_dead_time_beside_quadratic_damping_and_dry_friction(tmp_path):
    """The measured case: on a stiff finger at 500 Hz (steps, seed 0) the quadratic damping
    and dry friction are picked, and the last round's screen leaves the dead time out;
    fitted beside them it is significant, and all three are named."""
    from tests.diagnose.truth import combinations

    effects = ("dead_time", "coulomb_friction", "quadratic_damping")
    row = combinations.run(effects, "steps", 0, tmp_path)
    assert row["observable"]
    assert set(effects) <= set(row["named"])
