"""Second chances in the search (search/forward_selection.py, search/set_search.py), on
stand-ins for the fits: a round's best asked on a second held-out quarter, a runner-up that
gained beside the picks fitted again whatever the screen says, and pairs from the plain
refit when no effect alone passes."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import pytest

from hand_service.diagnose.search import forward_selection as fs
from hand_service.diagnose.search import set_search
from hand_service.diagnose.search.forward_selection import Round, Selection
from tests.diagnose.test_set_search import FakeCandidate, use_stand_ins


@pytest.mark.parametrize(("z", "bic", "expected", "asked"), [
    (0.4, 157.0, 3.7, True), (-0.5, 157.0, 3.7, True),  # far below what its gain predicts
    (0.3, 53.0, 2.2, False),  # near it: a stand-in's gain shrinking out of sample
    (-1.5, 157.0, 3.7, False), (0.4, 5.0, 3.7, False), (1.5, 157.0, 3.7, False)])
def test_a_strong_best_far_short_on_one_quarter_is_asked_on_a_second(monkeypatch, z, bic, expected,
                                                                       asked) -> None:
    """Strong in the fit, short of the borderline on the held-out quarter and far below what
    its gain predicts there, but not worse than the noise allows: the second quarter is asked
    (a borderline one already was)."""
    calls = []
    monkeypatch.setattr(fs, "second_split_z", lambda problem, base, fit: calls.append(fit) or 9.0)
    monkeypatch.setattr(fs, "expected_z", lambda problem, base, candidate: expected)
    best = fs.Candidate("coulomb_friction", None, 0.0, 0.0, 0.0, "fit", bic, z, 0.0)
    round_ = Round("base", [best])
    fs.second_look(None, round_)
    assert bool(calls) == asked
    assert round_.candidates[0].z_heldout == pytest.approx((z + 9.0) / np.sqrt(2.0) if asked else z)


def test_the_expected_z_follows_the_gain_in_the_fit() -> None:
    """ΔBIC 30 to 100 on a quarter held out expects z 1.6 to 2.9 (docs/diagnose-design.md)."""

    @dataclass
    class Stub:
        n_fit: int
        fit_mask: np.ndarray
        held_mask: np.ndarray

    n = 2000
    problem = Stub(1500, np.arange(n) % 4 != 0, np.arange(n) % 4 == 0)

    @dataclass
    class Fitted:
        params: list

    base = Fitted([1, 2, 3])
    for bic, lo, hi in ((30.0, 1.6, 1.9), (100.0, 2.8, 3.1), (157.0, 3.5, 3.8)):
        candidate = fs.Candidate("x", None, 0.0, 0.0, 0.0, Fitted([1, 2, 3, 4]), bic, 0.0, 0.0)
        assert fs.expected_z(problem, base, dataclasses.replace(candidate, delta_bic=bic + 900.0,
                                                                prior_gain=900.0)) == pytest.approx(
            fs.expected_z(problem, base, candidate))  # the prior's share is not the data's
        assert lo < fs.expected_z(problem, base, candidate) < hi


def test_a_runner_up_that_gained_beside_the_picks_is_fitted_in_the_next_round(monkeypatch) -> None:
    """Dry friction gains beside a valve lag in the second round but the dead time gains more;
    in the third round the screen would not fit friction beside the dead time: it is fitted."""
    rounds = {
        0: [FakeCandidate("valve_lag", "vl", True, 1300.0),
            FakeCandidate("coulomb_friction", "f", True, 150.0)],
        1: [FakeCandidate("dead_time", "vl+dt", True, 1800.0),
            FakeCandidate("coulomb_friction", "vl+f", True, 160.0)],
        2: [FakeCandidate("coulomb_friction", "vl+dt+f", True, 160.0)],
    }
    seen: list[tuple[str, ...]] = []

    def run_round(problem, base, names, progress, fit_all, standing=()):
        seen.append(tuple(standing))
        return Round(base, rounds[len(seen) - 1])

    monkeypatch.setattr(fs, "run_round", run_round)
    monkeypatch.setattr(fs, "second_look", lambda problem, round_: None)
    selection = fs.select(None, "refit", ["valve_lag", "dead_time", "coulomb_friction", "gravity"])
    assert seen == [(), (), ("coulomb_friction",)]  # the first round's runners-up are not carried
    assert [c.name for c in selection.accepted] == ["valve_lag", "dead_time", "coulomb_friction"]


# (the fit added to, the effect added): significant beside it? A valve lag and a dead time
# each lose alone against a refit that mimics both, and gain beside each other.
GAINS = {("refit+valve_lag", "dead_time"): True, ("refit+dead_time", "valve_lag"): True,
         ("refit+valve_lag+dead_time", "pressure_deadzone"): True}
SCREEN = {"pressure_deadzone": 50.0, "gravity": 20.0, "cubic_stiffness": 10.0, "valve_lag": -5.0,
          "dead_time": -8.0}


def unpicked_selection() -> Selection:
    round1 = [FakeCandidate("valve_lag", "refit+valve_lag", False, 1270.0),
              FakeCandidate("dead_time", "refit+dead_time", False, 770.0),
              FakeCandidate("pressure_deadzone", "refit+pressure_deadzone", True, 340.0),
              FakeCandidate("gravity", "refit+gravity", True, 97.0),
              FakeCandidate("cubic_stiffness", "refit+cubic_stiffness", False, 5.0)]
    return Selection(rounds=[Round("refit", round1)], accepted=[], final="refit")


@pytest.fixture
def stand_ins(monkeypatch):
    monkeypatch.setattr(set_search, "leaves_structure", lambda problem, final: True)
    return use_stand_ins(monkeypatch, GAINS, SCREEN)


def test_pairs_from_the_refit_led_by_what_gained_in_the_fits(stand_ins, monkeypatch) -> None:
    monkeypatch.setattr(set_search, "beats", lambda problem, base, members: True)
    found = set_search.search(None, unpicked_selection())
    assert found is not None
    assert [c.name for c in found.selection.accepted] == ["valve_lag", "dead_time", "pressure_deadzone"]
    assert stand_ins[:2] == [("refit", "valve_lag"), ("refit", "dead_time")]  # not the screen's order
    assert found.sentence().startswith("no effect alone passed every gate")
    assert all(any(c in r.candidates for r in found.selection.rounds) for c in found.selection.accepted)


def test_a_pair_that_does_not_beat_the_refit_is_not_taken(stand_ins, monkeypatch) -> None:
    monkeypatch.setattr(set_search, "beats", lambda problem, base, members: False)
    assert set_search.search(None, unpicked_selection()) is None


def test_no_pairs_where_nothing_gained_first_or_no_structure_is_left(stand_ins, monkeypatch) -> None:
    monkeypatch.setattr(set_search, "beats", lambda problem, base, members: True)
    weak = unpicked_selection()
    first = weak.rounds[0].candidates
    first[:] = [FakeCandidate(c.name, c.fit, False, 5.0) for c in first]
    assert set_search.search(None, weak) is None
    monkeypatch.setattr(set_search, "leaves_structure", lambda problem, final: False)
    assert set_search.search(None, unpicked_selection()) is None
    assert stand_ins == []

