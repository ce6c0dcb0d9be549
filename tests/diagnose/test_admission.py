"""The four effects searched behind the screen (search/admission.py): a stand-in for the
eight's physics is fitted only where its screen beats theirs by the naming margin, unless
the model file gives it or the user asks for it by name; and a Dahl loop is named over dry
friction only where it follows the raw angle better (else the two are a tie)."""

from __future__ import annotations

from dataclasses import dataclass, field
from types import SimpleNamespace

import numpy as np
import pytest

from hand_service.config import effects as fx
from hand_service.diagnose.fitting.raw_error import TIE_NOISE, TIE_SHARE
from hand_service.diagnose.model.params import Param
from hand_service.diagnose.requested import searched
from hand_service.diagnose.search import late_stand_in as late_module
from hand_service.diagnose.search.admission import (
    admitted,
    beside_a_tie,
    friction_rival,
    gated,
    kept,
    loop_beats_friction,
)
from hand_service.diagnose.search.forward_selection import NAME_MARGIN_BIC, Round, Selection
from hand_service.diagnose.search.late_stand_in import late_stand_in
from hand_service.diagnose.search.screening import Screen

FOUR = ("contact", "hysteresis", "pressure_stiffening", "creep")


def _problem(given: tuple[str, ...] = (), asked: tuple[str, ...] = (), n: int = 400) -> SimpleNamespace:
    """What admission.py reads of a Problem: the effects given and asked, and a recording."""
    t = np.arange(n) / 100.0
    measured = 10.0 * np.sin(t)
    fit_mask = np.arange(n) % 4 != 0
    return SimpleNamespace(given_effects={name: {} for name in given}, asked=frozenset(asked),
                           measured_deg=measured, fit_mask=fit_mask, held_mask=~fit_mask,
                           residual=lambda angle: measured - angle)


def _screen(name: str, white_bic: float) -> Screen:
    spec = fx.BY_NAME[name]  # the admission reads the names and the predicted gains only
    return Screen(name, Param.effect(name), 0.5, 0.5, [spec.neutral], white_bic, white_bic)


def test_three_of_the_four_are_searched_by_default_behind_the_screen() -> None:
    default = searched(())
    assert {"contact", "hysteresis", "creep"} <= set(default)
    # on request still: a lag's refinement, and the stiffening that stood in for a contact
    assert not {"valve_vent_lag", "pressure_stiffening"} & set(default)
    assert all(fx.BY_NAME[n].admitted_by_screen for n in FOUR)
    assert not any(fx.BY_NAME[n].admitted_by_screen for n in default if n not in FOUR)


def test_a_stand_in_is_fitted_only_past_the_naming_margin() -> None:
    problem = _problem()
    best = _screen("gravity", 300.0)
    screens = [best, _screen("coulomb_friction", 50.0),
               _screen("pressure_stiffening", 300.0 + NAME_MARGIN_BIC + 1.0),
               _screen("hysteresis", 300.0 + NAME_MARGIN_BIC - 1.0), _screen("creep", 20.0)]
    kept = [s.name for s in admitted(problem, screens, NAME_MARGIN_BIC)]
    assert kept == ["gravity", "coulomb_friction", "pressure_stiffening"]


def test_a_stand_in_asked_for_or_given_is_fitted_whatever_its_screen() -> None:
    screens = [_screen("cubic_stiffness", 552.0), _screen("contact", 448.0), _screen("creep", -5.0)]
    assert [s.name for s in admitted(_problem(asked=("contact",)), screens, NAME_MARGIN_BIC)] == [
        "cubic_stiffness", "contact"]
    assert [s.name for s in admitted(_problem(given=("creep",)), screens, NAME_MARGIN_BIC)] == [
        "cubic_stiffness", "creep"]
    assert gated(_problem(), "contact") and not gated(_problem(), "cubic_stiffness")


def test_with_none_of_the_eight_left_the_four_are_all_screened_in() -> None:
    screens = [_screen("contact", -3.0), _screen("creep", -8.0)]
    assert len(admitted(_problem(), screens, NAME_MARGIN_BIC)) == 2


def test_a_loop_beats_dry_friction_only_past_the_raw_tie_and_off_the_noise() -> None:
    noise = 0.2
    friction = 1.0
    assert loop_beats_friction((1.0 - 2.0 * TIE_SHARE) * friction, friction, noise)
    assert not loop_beats_friction((1.0 - 0.5 * TIE_SHARE) * friction, friction, noise)
    # both at the noise: one physics to the recording, however the two compare
    at_noise = TIE_NOISE * noise
    assert not loop_beats_friction(0.5 * at_noise, at_noise, noise)


@dataclass
class _Candidate:
    name: str
    angle_deg: np.ndarray
    significant: bool = True
    fit: SimpleNamespace = field(init=False)

    def __post_init__(self) -> None:
        self.fit = SimpleNamespace(angle_deg=self.angle_deg, sigma_deg=0.01)


def test_a_loop_that_dry_friction_draws_as_well_is_a_tie_with_it() -> None:
    problem = _problem()
    truth = problem.measured_deg
    rng = np.random.default_rng(0)
    off = rng.normal(0.0, 0.5, truth.size)
    loop = _Candidate("hysteresis", truth + off)
    friction = _Candidate("coulomb_friction", truth + 1.001 * off)
    remaining = ["coulomb_friction", "hysteresis"]
    unused = pytest.fail
    assert friction_rival(problem, loop, [loop, friction], remaining, unused) is friction
    # a loop that follows the raw angle clearly better is named
    better = _Candidate("hysteresis", truth + 0.5 * off)
    assert friction_rival(problem, better, [better, friction], remaining, unused) is None
    # dry friction that would not be named itself still ties on the raw angle
    weak = _Candidate("coulomb_friction", truth + off, significant=False)
    assert friction_rival(problem, loop, [loop, weak], remaining, unused) is weak
    # dry friction not fitted in the round is fitted beside the round's model
    fitted = []

    def beside(name: str) -> _Candidate:
        fitted.append(name)
        return friction

    assert friction_rival(problem, loop, [loop], remaining, beside) is friction and fitted == [
        "coulomb_friction"]
    # no loop named first, or dry friction already in the model: nothing to ask
    assert friction_rival(problem, friction, [friction, loop], remaining, unused) is None
    assert friction_rival(problem, loop, [loop], ["hysteresis"], unused) is None


def test_a_stand_in_accepted_late_with_more_evidence_than_the_first_pick_is_asked_again() -> None:
    """A contact screened out of the first round (its onset at the start's) and accepted
    beside the cubic spring picked there with ten times its ΔBIC: the selection runs again
    with the contact fitted from the first round (late_stand_in.py)."""
    pick = SimpleNamespace(name="cubic_stiffness", delta_bic=296.0)
    late = SimpleNamespace(name="contact", delta_bic=2907.0)
    assert late_stand_in(_problem(), Selection(accepted=[pick, late])) == "contact"
    # less evidence than the first pick, one of the eight, or one fitted from the first round
    # already (asked for, or given): the selection stands
    assert late_stand_in(_problem(), Selection(accepted=[pick, SimpleNamespace(name="contact",
                                                                                delta_bic=200.0)])) is None
    assert late_stand_in(_problem(), Selection(accepted=[pick, SimpleNamespace(name="gravity",
                                                                                delta_bic=900.0)])) is None
    assert late_stand_in(_problem(asked=("contact",)), Selection(accepted=[pick, late])) is None
    assert late_stand_in(_problem(), Selection(accepted=[late])) is None


def _uncarried(delta_bic: float, **gates: bool) -> SimpleNamespace:
    """A contact candidate significant in all but carrying itself (`gates` overrides a test)."""
    passed = {"predicts": True, "at_bound": False, "determined": True, "carries": False, **gates}
    return SimpleNamespace(name="contact", delta_bic=delta_bic, **passed)


def test_a_stand_in_kept_out_after_the_first_round_only_for_its_core_is_asked_again() -> None:
    """The truth's contact on steps (stiff, 100 Hz): a cubic spring picked first (ΔBIC 291),
    then beside it the contact gained 1 979 but its spring alone, beside the cubic that took
    the spring's share, did not carry itself: the selection runs again with the contact
    fitted from the first round, where its spring is judged against the plain model
    (late_stand_in.py, docs/results.md §12.60)."""
    pick = SimpleNamespace(name="cubic_stiffness", delta_bic=291.0)

    def selection(*later: SimpleNamespace, first_round: tuple[SimpleNamespace, ...] = ()) -> Selection:
        return Selection(rounds=[Round("refit", [pick], list(first_round)), Round("cubic", [], list(later))],
                         accepted=[pick])

    assert late_stand_in(_problem(), selection(_uncarried(1979.0))) == "contact"
    # less evidence than the first pick; short of another test; in the first round (judged
    # against the plain model already); or fitted from the first round already
    assert late_stand_in(_problem(), selection(_uncarried(200.0))) is None
    for gate in ({"predicts": False}, {"at_bound": True}, {"determined": False}, {"carries": True}):
        assert late_stand_in(_problem(), selection(_uncarried(1979.0, **gate))) is None, gate
    assert late_stand_in(_problem(), selection(first_round=(_uncarried(1979.0),))) is None
    assert late_stand_in(_problem(asked=("contact",)), selection(_uncarried(1979.0))) is None


@dataclass(frozen=True)
class _Asked:
    """What select_screened reads of a Problem, and replaces: the effects given and asked."""

    given_effects: dict = field(default_factory=dict)
    asked: frozenset[str] = frozenset()


def test_the_second_selection_for_an_uncarried_stand_in_stands_only_where_it_names_it(monkeypatch) -> None:
    """Run again for a stand-in that did not carry itself, the selection is kept only where the
    stand-in is accepted in it; for one accepted late, as before, whatever it finds."""
    pick = SimpleNamespace(name="cubic_stiffness", delta_bic=291.0)
    first = Selection(rounds=[Round("refit", [pick]), Round("cubic", [], [_uncarried(1979.0)])],
                      accepted=[pick])
    for again_accepts, expected in (([SimpleNamespace(name="contact", delta_bic=2500.0)], "again"),
                                    ([pick], "first")):
        again = Selection(accepted=again_accepts)
        calls: list[frozenset[str]] = []

        def select(problem, refit, names, progress=None, first=first, again=again, calls=calls):
            calls.append(problem.asked)
            return first if len(calls) == 1 else again

        monkeypatch.setattr(late_module, "select", select)
        got = late_module.select_screened(_Asked(), "refit", [])
        assert calls == [frozenset(), frozenset({"contact"})]
        assert got is (again if expected == "again" else first)
    accepted_late = Selection(accepted=[pick, SimpleNamespace(name="contact", delta_bic=2907.0)])
    again = Selection(accepted=[pick])
    monkeypatch.setattr(late_module, "select",
                        lambda problem, *a, **k: accepted_late if not problem.asked else again)
    assert late_module.select_screened(_Asked(), "refit", []) is again


@pytest.mark.thorough
def test_a_contact_screened_out_of_the_first_round_is_named_alone(tmp_path) -> None:
    """The independent truth's contact (Hunt-Crossley, stiff finger, vent release at 1 kHz,
    3.3 times the noise): behind the screen a cubic spring was picked first and the contact
    beside it (ΔBIC 296, then 2 907: docs/results.md §12.52); asked again from the first
    round, the contact is named alone."""
    from tests.diagnose.checked import diagnosed
    from tests.diagnose.truth import cases as cs

    case = cs.build(cs.CaseSpec("contact", "vent_release", 0, "evident", family="stiff", rate_hz=1000.0,
                                strength=5.0))
    assert case.visibility > 3.0, case.visibility
    d = diagnosed(*cs.write(case, tmp_path))
    assert [e.name for e in d.effects] == ["contact"], d.warnings


@pytest.mark.thorough
def test_a_contact_behind_a_tie_of_the_eight_is_named(tmp_path) -> None:
    """The battery's evident contact under PI steps (s0, ringing, 100 Hz): gravity and a cubic
    spring tie in the first round, the contact's screen below the cubic's; without the guard
    it never entered a round (`insufficient_excitation`, docs/results.md §12.60). Fitted
    beside the tie (`beside_a_tie`) it is named alone."""
    from tests.diagnose.checked import diagnosed
    from tests.diagnose.truth import cases as cs

    case = cs.build(cs.CaseSpec("contact", "pi_steps", 0, "evident"))
    d = diagnosed(*cs.write(case, tmp_path))
    assert [e.name for e in d.effects] == ["contact"], d.warnings
    assert d.grade == "complete", d.warnings


@dataclass
class _Scored(_Candidate):
    delta_bic: float = 0.0


def test_a_stand_in_stays_in_its_round_only_where_it_beats_the_eight_on_the_raw_angle() -> None:
    """A stiffening that out-gains gravity on the innovations stays only where its model, simulated
    from the command, follows the raw angle better than gravity's, than the model before it in a
    later round, and than the eight's best two together, each past the raw tie."""
    problem = _problem()
    truth = problem.measured_deg
    off = np.random.default_rng(1).normal(0.0, 0.5, truth.size)
    base = SimpleNamespace(angle_deg=truth + 2.0 * off)
    gravity = _Scored("gravity", truth + off, delta_bic=750.0)
    cubic = _Scored("cubic_stiffness", truth + 1.2 * off, delta_bic=660.0)
    pair_fits: list[str] = []

    def pair(first_fit: SimpleNamespace, name: str, raw_share: float) -> SimpleNamespace:
        pair_fits.append(name)
        return SimpleNamespace(fit=SimpleNamespace(angle_deg=truth + raw_share * off))

    def names(candidates: list[_Scored], later: bool, pair_share: float) -> list[str]:
        return [c.name for c in kept(problem, base, candidates, later,
                                     lambda f, n: pair(f, n, pair_share))]

    close = _Scored("pressure_stiffening", truth + (1.0 - 0.5 * TIE_SHARE) * off, delta_bic=840.0)
    assert names([close, gravity, cubic], False, 0.5) == ["gravity", "cubic_stiffness"]
    better = _Scored("pressure_stiffening", truth + 0.8 * off, delta_bic=840.0)
    assert names([better, gravity, cubic], False, 0.9) == [
        "pressure_stiffening", "gravity", "cubic_stiffness"]
    assert pair_fits == ["cubic_stiffness"]
    # the eight's best two together follow the raw angle closer: one physics drawn as two
    assert names([better, gravity, cubic], False, 0.7) == ["gravity", "cubic_stiffness"]
    # not significant, or not past the model before it in a later round
    weak = _Scored("pressure_stiffening", truth + 0.8 * off, significant=False, delta_bic=840.0)
    assert names([weak, gravity], False, 0.5) == ["gravity"]
    later = _Scored("creep", truth + 1.99 * off, delta_bic=40.0)
    assert names([later], True, 0.5) == [] and names([later], False, 0.5) == ["creep"]
    # at the noise too: the share decides (the innovations judged the gain real)
    at_noise = _Scored("creep", truth + 0.8 * off, delta_bic=40.0)
    at_noise.fit.sigma_deg = 10.0
    assert names([at_noise, gravity], False, 0.5) == ["creep", "gravity"]
    # but a later round's stand-in beside a model so far at the noise is not added
    beside = _Scored("creep", truth + 0.9 * off, delta_bic=40.0)
    beside.fit.sigma_deg = 10.0
    assert names([beside], True, 0.5) == []
    beside.fit.sigma_deg = 0.01
    assert names([beside], True, 0.5) == ["creep"]
    # a loop is not judged against dry friction here (friction_rival is), and the eight stay
    loop = _Scored("hysteresis", truth + 1.001 * off, delta_bic=300.0)
    friction = _Scored("coulomb_friction", truth + off, delta_bic=200.0)
    assert names([loop, friction], False, 0.5) == ["hysteresis", "coulomb_friction"]


def test_a_stand_in_the_screen_kept_out_is_fitted_beside_a_tie_of_the_eight() -> None:
    """The truth's contact under PI steps (ringing, 100 Hz): gravity and a cubic spring tie in
    the first round (ΔBIC 306 and 298), the contact's screen fell below theirs; fitted beside
    the tie it follows the raw angle closer than both and joins the round (admission.py)."""
    problem = _problem()
    truth = problem.measured_deg
    off = np.random.default_rng(1).normal(0.0, 0.5, truth.size)

    def scored(name: str, delta_bic: float, share: float) -> SimpleNamespace:
        candidate = _Candidate(name, truth + share * off)
        return SimpleNamespace(name=name, fit=candidate.fit, significant=True, delta_bic=delta_bic)

    tie = [scored("gravity", 306.0, 1.0), scored("cubic_stiffness", 298.0, 1.01)]
    contact = scored("contact", 1251.0, 0.7)
    fitted: list[str] = []

    def fit_screened(s: Screen) -> SimpleNamespace:
        fitted.append(s.name)
        return contact

    out = [_screen("contact", 100.0)]
    assert beside_a_tie(problem, tie, out, NAME_MARGIN_BIC, fit_screened) == [contact]
    assert fitted == ["contact"]
    # no tie (the best clear of the runner-up by the margin): nothing fitted
    clear = [scored("gravity", 306.0 + NAME_MARGIN_BIC, 1.0), tie[1]]
    assert beside_a_tie(problem, clear, out, NAME_MARGIN_BIC, pytest.fail) == []
    # a stand-in no closer than one of the tied by the raw tie share: not kept
    near = scored("contact", 1251.0, 1.0 - 0.5 * TIE_SHARE)
    assert beside_a_tie(problem, tie, out, NAME_MARGIN_BIC, lambda s: near) == []
    weak = scored("contact", 1251.0, 0.7)
    weak.significant = False
    assert beside_a_tie(problem, tie, out, NAME_MARGIN_BIC, lambda s: weak) == []
    # a stand-in the screen let in, significant, already as close to the raw angle: not kept
    creep = scored("creep", 400.0, 0.7 * (1.0 - 0.5 * TIE_SHARE))
    assert beside_a_tie(problem, [creep, *tie], out, NAME_MARGIN_BIC, fit_screened) == []
    creep.significant = False
    assert beside_a_tie(problem, [creep, *tie], out, NAME_MARGIN_BIC, fit_screened) == [contact]
