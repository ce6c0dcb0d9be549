"""A set named over structure left (search/set_members.py) and a first-round tie asked again
beside the effects found since (search/tie_revisit.py): their rules on stand-ins for the
fits (cheap)."""

from __future__ import annotations

from dataclasses import dataclass

from hand_service.diagnose.search import set_members, tie_revisit
from hand_service.diagnose.search.forward_selection import Selection
from hand_service.diagnose.search.set_members import Member, Standing


def test_a_set_stands_out_where_each_member_explains_more_than_all_that_is_left() -> None:
    # the measured triple's figures: the set 0.457 deg, the sensor's white noise 0.147
    members = (Member("coulomb_friction", 0.729), Member("asymmetric_stiffness", 0.732),
               Member("gravity", 1.07))
    standing = Standing(0.457, 0.147, members)
    assert standing.all_stand_out
    assert "without gravity 1.07" in standing.sentence()


def test_a_member_that_takes_less_than_what_is_left_keeps_the_set_from_being_named() -> None:
    # what the set leaves above the noise: 0.8² − 0.1² = 0.63 deg²; the second member adds 0.36
    standing = Standing(0.8, 0.1, (Member("coulomb_friction", 1.6), Member("quadratic_damping", 1.0)))
    assert standing.stands_out(standing.members[0])
    assert not standing.stands_out(standing.members[1])
    assert not standing.all_stand_out


def test_a_member_that_ties_with_the_set_at_the_noise_does_not_stand_out() -> None:
    # Silverbox's figures at 610 Hz: the cubic spring takes the raw error to the noise; gravity
    # and a dead time beside it move it by a percent or two, nothing is left above the noise
    standing = Standing(0.329, 0.329, (Member("cubic_stiffness", 3.49), Member("gravity", 0.334),
                                       Member("dead_time", 0.332)))
    assert standing.stands_out(standing.members[0])
    assert standing.ties_without(standing.members[1]) and not standing.stands_out(standing.members[1])
    assert not standing.all_stand_out
    # the same set further from the noise: the gravity's percent is judged against what is left
    assert not Standing(0.329, 0.1, standing.members).ties_without(standing.members[1])


def test_no_members_is_no_set() -> None:
    assert not Standing(0.5, 0.1, ()).all_stand_out


@dataclass
class FakeCandidate:
    name: str
    fit: str
    significant: bool
    delta_bic: float


def tie_selection() -> Selection:
    valve = FakeCandidate("valve_lag", "refit+valve_lag", True, 120.0)
    dead = FakeCandidate("dead_time", "refit+dead_time", True, 115.0)
    friction = FakeCandidate("coulomb_friction", "refit+valve_lag+coulomb_friction", True, 900.0)
    return Selection(rounds=[], accepted=[friction], final=friction.fit, ambiguous=(valve, dead),
                     carried=[valve])


def stand_ins(monkeypatch, gains: dict[str, tuple[bool, float]]) -> list[tuple[str, str]]:
    calls: list[tuple[str, str]] = []

    def beside(problem, base, name):
        calls.append((base, name))
        significant, bic = gains[name]
        return FakeCandidate(name, f"{base}+{name}", significant, bic)

    monkeypatch.setattr(tie_revisit, "without", lambda problem, final, name: final.replace(f"+{name}", ""))
    monkeypatch.setattr(tie_revisit, "beside", beside)
    return calls


def test_a_tie_told_apart_beside_the_second_effect_names_the_winner(monkeypatch) -> None:
    calls = stand_ins(monkeypatch, {"valve_lag": (True, 300.0), "dead_time": (True, 150.0)})
    resolved = tie_revisit.revisit(None, tie_selection())
    assert resolved is not None
    assert [c.name for c in resolved.selection.accepted] == ["coulomb_friction", "valve_lag"]
    assert resolved.selection.final == "refit+coulomb_friction+valve_lag"
    assert resolved.selection.ambiguous is None and resolved.selection.carried == []
    assert calls == [("refit+coulomb_friction", "valve_lag"), ("refit+coulomb_friction", "dead_time")]
    assert "ΔBIC 150 over dead_time" in resolved.sentence()


def test_a_tie_that_stands_beside_the_second_effect_is_left_as_it_was(monkeypatch) -> None:
    stand_ins(monkeypatch, {"valve_lag": (True, 300.0), "dead_time": (True, 295.0)})
    assert tie_revisit.revisit(None, tie_selection()) is None


def test_the_winner_must_pass_the_gate_beside_the_others(monkeypatch) -> None:
    stand_ins(monkeypatch, {"valve_lag": (False, 300.0), "dead_time": (False, 150.0)})
    assert tie_revisit.revisit(None, tie_selection()) is None


def test_no_tie_nothing_refitted(monkeypatch) -> None:
    calls = stand_ins(monkeypatch, {})
    selection = tie_selection()
    selection.ambiguous, selection.carried = None, []
    assert tie_revisit.revisit(None, selection) is None
    assert calls == []


# dead time, dry friction and a dead zone on steps (500 Hz), the measured figures: the 5 ms
# dead time left out raises the set's raw error less than all the set leaves above the noise
GREEDY = Standing(0.322, 0.063, (Member("dead_time", 0.424), Member("coulomb_friction", 0.555),
                                 Member("pressure_deadzone", 1.376)))
# the two that stand out, fitted again without the dead time
ALONE = Standing(0.424, 0.063, (Member("coulomb_friction", 0.616), Member("pressure_deadzone", 1.4)))


def stand_out_stand_ins(monkeypatch, alone: Standing, significant: bool = True) -> list[tuple[str, str]]:
    fitted: list[tuple[str, str]] = []

    def added(problem, base, name):
        fitted.append((base, name))
        return FakeCandidate(name, f"{base}+{name}", significant, 500.0)

    monkeypatch.setattr(set_members, "beside", added)
    monkeypatch.setattr(set_members, "standing", lambda problem, final, names, fitting, held: alone)
    return fitted


def test_the_members_that_stand_out_are_fitted_again_and_named_without_the_others(monkeypatch) -> None:
    assert not GREEDY.all_stand_out
    fitted = stand_out_stand_ins(monkeypatch, ALONE)
    got = set_members.stand_out(None, "refit", GREEDY, None, None)
    assert got is not None
    assert fitted == [("refit", "coulomb_friction"), ("refit+coulomb_friction", "pressure_deadzone")]
    assert [c.name for c in got.selection.accepted] == ["coulomb_friction", "pressure_deadzone"]
    assert got.selection.final == "refit+coulomb_friction+pressure_deadzone"
    assert got.dropped == ("dead_time",)
    assert "dead_time explains less" in got.sentence()


def test_no_members_are_named_apart_where_they_do_not_stand_out_in_their_own_fit(monkeypatch) -> None:
    # without the dead time, the friction's share falls under what is left
    stand_out_stand_ins(monkeypatch, Standing(0.6, 0.063, (Member("coulomb_friction", 0.65),
                                                           Member("pressure_deadzone", 1.4))))
    assert set_members.stand_out(None, "refit", GREEDY, None, None) is None


def test_no_members_are_named_apart_where_one_fails_the_gate_refitted(monkeypatch) -> None:
    stand_out_stand_ins(monkeypatch, ALONE, significant=False)
    assert set_members.stand_out(None, "refit", GREEDY, None, None) is None


def test_a_set_whose_members_all_stand_out_or_none_is_not_split(monkeypatch) -> None:
    fitted = stand_out_stand_ins(monkeypatch, ALONE)
    everyone = Standing(0.457, 0.147, (Member("coulomb_friction", 0.729), Member("gravity", 1.07)))
    nobody = Standing(0.8, 0.1, (Member("coulomb_friction", 0.85), Member("gravity", 0.9)))
    assert set_members.stand_out(None, "refit", everyone, None, None) is None
    assert set_members.stand_out(None, "refit", nobody, None, None) is None
    assert fitted == []
