"""The forward selection again from other first picks (search/other_first.py): its logic on
stand-ins for the fits (cheap), and the measured case on the truth generator (thorough)."""

from __future__ import annotations

from dataclasses import dataclass

import pytest

from hand_service.diagnose.model.params import Param
from hand_service.diagnose.search import other_first
from hand_service.diagnose.search.forward_selection import Candidate, Round, Selection


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


@dataclass
class PinnedFit:
    """A set's final fit as earns_places reads it: each effect's size by its label."""
    sizes: dict[str, float]

    def value(self, label: str, member: str = "") -> float:
        return self.sizes[label]


def _member(name: str, fit: object) -> Candidate:
    return Candidate(name, Param.effect(name), 0.9, 0.5, 0.0, fit, 500.0, 5.0, 0.2)


def test_a_set_with_a_member_pinned_at_its_bound_does_not_earn_its_place(monkeypatch):
    """Gravity at the end of its plausible range in the set's fit is stretched to mimic
    something else (the gate's `at_bound`), however its refit beside the others lands; inside
    the range, the refits decide."""
    refits: list[str] = []

    def beside(problem, base, name, lazy=False):
        refits.append(name)
        return _member(name, PinnedFit({name: 0.1}))

    monkeypatch.setattr(other_first, "beside", beside)
    monkeypatch.setattr(other_first, "without", lambda problem, final, name: final)
    for gravity_nm, earns in ((Param.effect("gravity").lower, False), (-0.3, True)):
        final = PinnedFit({"gravity": gravity_nm, "pressure_stiffening": 0.37})
        members = [_member("gravity", PinnedFit({"gravity": -0.2})),
                   _member("pressure_stiffening", final)]
        with monkeypatch.context() as m:
            m.setattr(Candidate, "significant", property(lambda c: True))
            assert other_first.earns_places(None, Selection(accepted=members, final=final)) is earns
    assert refits == ["gravity"]  # the pinned set is turned down before any refit


def stiffening_behind_the_screen(monkeypatch) -> None:
    """diagnose's search with the stiffening (searched on request) behind the screen, as the
    default search takes contact, hysteresis and creep: fitted only past its screen."""
    from hand_service.diagnose import requested

    monkeypatch.setattr("hand_service.diagnose.engine.searched",
                        lambda also: [*requested.searched(also), "pressure_stiffening"])


@pytest.mark.thorough
def test_a_damping_that_grows_with_pressure_is_not_named_complete_by_a_pinned_pair(tmp_path, monkeypatch):
    """Outside the library: the independent truth's damping that grows with the chamber
    pressure, under FF+PID on the paper's cosine (over-damped, 200 Hz, seed 0), the stiffening
    searched behind the screen. From gravity, the other path found gravity and pressure
    stiffening following the recording to its noise, `complete`, with gravity at the end of
    its range (−0.5 N·m): no effect pinned at a bound is named, and no library name is graded
    `complete`."""
    from hand_service.config import effects as fx
    from hand_service.config.profile import load_model
    from hand_service.diagnose.engine import diagnose
    from hand_service.diagnose.recording.timebase import regular_grid
    from hand_service.recording import read_recording
    from tests.diagnose.truth import cases as cs

    stiffening_behind_the_screen(monkeypatch)
    spec = cs.CaseSpec("pressure_damping", "ffpid_cosine", 0, "evident", family="overdamped", rate_hz=200.0)
    rec_path, model_path = cs.write(cs.build(spec), tmp_path)
    rec = read_recording(rec_path, None)
    grid = regular_grid(rec.t_s, rec.pressure_kpa, rec.angle_deg, rec_path)
    d = diagnose(load_model(model_path, None), grid.t_s, grid.pressure_kpa, grid.angle_deg, grid.rate_hz)
    for e in d.effects:
        for p in fx.BY_NAME[e.name].parameters:
            if p.fitted and p.name in e.params:  # within the gate's 1e-6 of the span: pinned
                margin = 1e-6 * (p.upper - p.lower)
                assert p.lower + margin < e.params[p.name] < p.upper - margin, (e.name, e.params)
    assert not (d.effects and d.grade == "complete"), (d.verdict, d.grade, d.warnings)


@pytest.mark.parametrize("path_raw_deg, taken", [(0.276, True), (0.315, False)])
def test_a_path_that_names_a_stand_in_must_follow_the_raw_angle_closer(monkeypatch, path_raw_deg, taken):
    """The first path named a valve lag and gravity (0.319 deg from the raw angle); from the
    stiffening, a path gains more on the innovations: it replaces the first only where it is
    closer to the raw angle by the tie share (admission.kept's rule for a stand-in)."""
    path = ["pressure_stiffening", "valve_lag"]
    use_stand_ins(monkeypatch, {"pressure_stiffening": (path, 2824.0)}, 2726.0)
    raws = {"first": 0.319, "path:pressure_stiffening+valve_lag": path_raw_deg}
    monkeypatch.setattr(other_first, "set_raw_deg", lambda problem, final: raws[final])
    monkeypatch.setattr(other_first, "gated", lambda problem, name: name == "pressure_stiffening")
    round1 = {"valve_lag": 900.0, "pressure_stiffening": 880.0, "gravity": 700.0}
    selection = first_path(["valve_lag", "gravity"], round1)
    selection.final = "first"
    found = other_first.search(None, "refit", selection, list(round1))
    assert (found is not None) is taken
