"""A stand-in named beside other effects, asked again in their company (search/stand_in_place.py):
its logic on stand-ins for the fits (cheap), and the measured case on the truth's combinations
(thorough)."""

from __future__ import annotations

from dataclasses import dataclass

import pytest

from hand_service.diagnose.fitting.raw_error import TIE_SHARE
from hand_service.diagnose.report.sentence_checks import Facts, failures
from hand_service.diagnose.search import stand_in_place
from hand_service.diagnose.search.forward_selection import Round, Selection

SEARCHED = ["valve_lag", "cubic_stiffness", "gravity", "coulomb_friction", "pressure_stiffening", "creep"]
STAND_INS = {"pressure_stiffening", "creep", "contact", "hysteresis"}


@dataclass(frozen=True)
class FakeFit:
    label: str
    raw_deg: float


@dataclass
class FakeCandidate:
    name: str
    fit: FakeFit
    significant: bool = True
    delta_bic: float = 500.0


def use_stand_ins(monkeypatch, beside_rest: dict[str, tuple[float, bool, float]],
                  pair: tuple[float, bool] | None = None) -> list[str]:
    """Each library effect fitted in the stand-in's place: (its set's raw RMS error, passes
    the gate, ΔBIC); `pair`: the second of the two strongest fitted beside the first. The
    names fitted, in order."""
    fitted: list[str] = []

    def beside(problem, base, name, lazy=False):
        fitted.append(name)
        if base.label != "rest":
            raw, significant = pair
            return FakeCandidate(name, FakeFit(f"{base.label}+{name}", raw), significant)
        raw, significant, bic = beside_rest.get(name, (9.0, False, -8.0))
        return FakeCandidate(name, FakeFit(f"rest+{name}", raw), significant, bic)

    monkeypatch.setattr(stand_in_place, "beside", beside)
    monkeypatch.setattr(stand_in_place, "without", lambda problem, final, name: FakeFit("rest", 9.0))
    monkeypatch.setattr(stand_in_place, "raw_deg", lambda problem, angle: angle)
    monkeypatch.setattr(stand_in_place, "gated", lambda problem, name: name in STAND_INS)
    monkeypatch.setattr(FakeFit, "angle_deg", property(lambda f: f.raw_deg), raising=False)
    return fitted


def picked(names: list[str], raw_deg: float) -> Selection:
    """A path that accepted `names`, its final fit `raw_deg` from the raw angle."""
    final = FakeFit("+".join(names), raw_deg)
    return Selection(rounds=[Round(FakeFit("refit", 1.0), [])],
                     accepted=[FakeCandidate(n, final) for n in names], final=final)


def test_the_library_effect_that_draws_the_raw_angle_as_closely_takes_the_stand_ins_place(monkeypatch):
    """The measured case's shape: a stiffening and a valve lag named, the cubic spring beside
    the lag 5 % closer to the raw angle (0.253 against 0.265 deg)."""
    fitted = use_stand_ins(monkeypatch, {"cubic_stiffness": (0.253, True, 661.0),
                                         "gravity": (0.30, True, 700.0)})
    placed = stand_in_place.revisit(None, picked(["pressure_stiffening", "valve_lag"], 0.265), SEARCHED)
    assert placed is not None
    assert [c.name for c in placed.selection.accepted] == ["valve_lag", "cubic_stiffness"]
    assert placed.selection.final.label == "rest+cubic_stiffness"
    assert set(fitted) == {"cubic_stiffness", "gravity", "coulomb_friction"}  # no stand-in, nothing named
    facts = Facts(200.0, None, False, 1.0, None, 4000)
    assert failures(placed.sentence(), facts) == [], placed.sentence()
    assert "cubic_stiffness follows the raw angle within 2 % of it or closer" in placed.sentence()


@pytest.mark.parametrize("shares, takes", [(0.5, True), (1.5, False)])
def test_within_the_tie_share_the_library_effect_takes_the_place_beyond_it_not(monkeypatch, shares, takes):
    """The stand-in's set closer to the raw angle by `shares` of the tie share."""
    own = 0.265
    use_stand_ins(monkeypatch, {"gravity": (own / (1.0 - shares * TIE_SHARE), True, 700.0)})
    placed = stand_in_place.revisit(None, picked(["pressure_stiffening", "valve_lag"], own), SEARCHED)
    assert (placed is not None) is takes


def test_a_library_effect_that_fails_the_gate_does_not_take_the_place(monkeypatch):
    use_stand_ins(monkeypatch, {"cubic_stiffness": (0.20, False, 120.0)})
    assert stand_in_place.revisit(None, picked(["pressure_stiffening", "valve_lag"], 0.265), SEARCHED) is None


def test_a_stand_in_named_alone_or_a_set_without_one_is_not_asked(monkeypatch):
    fitted = use_stand_ins(monkeypatch, {"gravity": (0.10, True, 700.0)})
    assert stand_in_place.revisit(None, picked(["pressure_stiffening"], 0.265), SEARCHED) is None
    assert stand_in_place.revisit(None, picked(["valve_lag", "gravity"], 0.265), SEARCHED) is None
    assert fitted == []


@pytest.mark.parametrize("second_passes", [False, True])
def test_two_of_the_library_that_draw_it_as_one_physics(monkeypatch, second_passes):
    """No effect alone comes within the tie; gravity and a cubic spring together do (a weight
    mounted at an angle): where the spring beside gravity fails the gate, gravity alone takes
    the stand-in's place, and the sentence says so."""
    use_stand_ins(monkeypatch, {"gravity": (0.319, True, 749.0), "cubic_stiffness": (0.374, True, 661.0)},
                  pair=(0.252, second_passes))
    placed = stand_in_place.revisit(None, picked(["pressure_stiffening", "valve_lag"], 0.276), SEARCHED)
    assert placed is not None
    names = ["valve_lag", "gravity", *(["cubic_stiffness"] if second_passes else [])]
    assert [c.name for c in placed.selection.accepted] == names
    assert placed.drawn_by == ("gravity", "cubic_stiffness")
    facts = Facts(200.0, None, False, 1.0, None, 4000)
    assert failures(placed.sentence(), facts) == [], placed.sentence()
    if not second_passes:
        assert "cubic_stiffness does not pass the gate beside gravity, so gravity alone" in placed.sentence()


def test_no_pair_beyond_the_sets_room(monkeypatch):
    """Three effects at most (forward_selection.MAX_EFFECTS): beside two others, one at most."""
    alone = {"gravity": (0.319, True, 749.0), "cubic_stiffness": (0.374, True, 661.0)}
    fitted = use_stand_ins(monkeypatch, alone, pair=(0.252, True))
    selection = picked(["pressure_stiffening", "valve_lag", "coulomb_friction"], 0.276)
    assert stand_in_place.revisit(None, selection, SEARCHED) is None
    assert len(fitted) == 2  # gravity and the spring in its place, no pair


@pytest.mark.thorough
def test_a_valve_lag_and_a_cubic_spring_are_named_not_a_stiffening_chamber(tmp_path, monkeypatch):
    """The measured case (the truth's combinations, multisine, seed 0, over-damped, 200 Hz),
    the stiffening searched behind the screen (on request by default): the spring alone failed
    the first round's gate, the stiffening was kept, the lag found beside it, and the pair
    graded `complete`. Asked again beside the lag, the spring takes its place: both missing
    effects are named, the stiffening is not."""
    from hand_service.config.profile import load_model
    from hand_service.diagnose.engine import diagnose
    from hand_service.diagnose.recording.timebase import regular_grid
    from hand_service.recording import read_recording
    from tests.diagnose.test_other_first import stiffening_behind_the_screen
    from tests.diagnose.truth import cases as cs
    from tests.diagnose.truth import combinations

    stiffening_behind_the_screen(monkeypatch)
    case = combinations.build(("valve_lag", "cubic_stiffness"), "multisine", 0)
    assert case is not None  # every single-effect case observable
    rec_path, model_path = cs.write(case, tmp_path)
    rec = read_recording(rec_path, None)
    grid = regular_grid(rec.t_s, rec.pressure_kpa, rec.angle_deg, rec_path)
    d = diagnose(load_model(model_path, None), grid.t_s, grid.pressure_kpa, grid.angle_deg, grid.rate_hz)
    named = [e.name for e in d.effects]
    assert {"valve_lag", "cubic_stiffness"} <= set(named), (named, d.warnings)
    assert "pressure_stiffening" not in named
    assert any(w.startswith("pressure_stiffening was named beside valve_lag") for w in d.warnings), d.warnings
