"""The rival before the grade `complete` (search/rival_check.py, search/loop_rival.py): an
effect the search did not try, fitted in place of the named ones, that would be named had it
been searched and that the raw angle cannot tell from the named model (a Diebold-Mariano test
on their squared raw errors, fitting/raw_difference.py), or finds better, keeps the grade from
`complete`, and is said."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.signal import lfilter

from hand_service.diagnose.fitting.raw_difference import LossDifference, loss_difference
from hand_service.diagnose.report.sentence_checks import Facts, failures
from hand_service.diagnose.search.rival_check import RIVALS, Rival, rivals_to_try
from tests.diagnose.checked import diagnosed, report_failures
from tests.diagnose.truth import cases as cs


def _rival(rival_raw_deg: float, z: float, named_raw_deg: float = 0.30, significant: bool = True,
           loop: bool = False) -> Rival:
    difference = LossDifference(z * 1e-3, 1e-3, 150, 20, 3000)
    return Rival("pressure_stiffening", ("gravity",), {"gain": 0.42}, 120.0, significant, rival_raw_deg,
                 named_raw_deg, 0.30, difference, loop)


def _ar1(rho: float, n: int, rng: np.random.Generator) -> np.ndarray:
    """A unit-variance AR(1) series, started in its stationary state."""
    drive = np.sqrt(1.0 - rho * rho) * rng.standard_normal(n)
    drive[0] = rng.standard_normal()
    return lfilter([1.0], [1.0, -rho], drive)


def test_a_difference_of_slow_swings_is_not_taken_for_certain() -> None:
    """Two models equally accurate on average, whose misfits swing slowly (a persistent loss
    difference): the test must not call them apart, where the difference's plain variance
    γ₀/n would, most of the time; and its blocks follow the persistence."""
    rng = np.random.default_rng(7)
    n, calls, naive = 3000, 0, 0
    for _ in range(40):
        noise = 0.3 * rng.standard_normal(n)
        a = noise + 0.2 * _ar1(0.995, n, rng)  # each model's misfit a slow swing of its own,
        b = noise + 0.2 * _ar1(0.995, n, rng)  # of the same size: equally accurate on average
        d = b * b - a * a
        test = loss_difference(a, b)
        calls += test.apart
        naive += abs(d.mean() / (d.std() / np.sqrt(n))) > 1.645
    assert calls <= 8 and naive >= 20, (calls, naive)
    white = loss_difference(rng.standard_normal(n), rng.standard_normal(n))
    assert white.block_samples < test.block_samples


def test_a_small_steady_excess_is_found_over_many_samples() -> None:
    """A rival whose raw error is 2 % above the named model's on every stretch of a long
    recording is worse, though a 2 % share was once a tie: the raw angle tells them apart."""
    rng = np.random.default_rng(3)
    n = 20000
    a = 0.3 * rng.standard_normal(n)
    b = a + 0.061 * rng.standard_normal(n)  # about 2 % more raw RMS error, white
    assert np.sqrt(np.mean(b * b)) <= 1.03 * np.sqrt(np.mean(a * a))
    test = loss_difference(a, b)
    assert test.b_worse and not test.b_better
    assert loss_difference(b, a).b_better


def test_a_rival_the_raw_angle_cannot_tell_apart_stands() -> None:
    tie = _rival(0.40, z=1.0)  # 1.33 times the named model's error, within the recording's fluctuation
    assert tie.stands and not tie.better
    assert "cannot tell them apart" in tie.sentence()
    assert "the grade is not complete" in tie.sentence()


def test_a_better_rival_stands_and_says_so() -> None:
    better = _rival(0.28, z=-2.0)
    assert better.stands and better.better
    assert "better than the model with gravity" in better.sentence()
    assert better.to_json()["better"] is True


def test_a_better_rivals_sentence_says_nothing_is_named() -> None:
    better, tie = _rival(0.28, z=-2.0), _rival(0.40, z=1.0)
    assert "the recording favours it, so no effect is named" in better.sentence()
    assert "the grade is not complete" not in better.sentence()
    assert "no effect is named" not in tie.sentence()


@pytest.mark.thorough
def test_where_the_raw_angle_favours_the_rival_nothing_is_named(tmp_path: Path) -> None:
    """The independent truth's chamber stiffening with pressure, PI steps through an
    over-damped finger at 500 Hz, evident: the default search named `gravity` and graded it
    `dominant` while the stiffening, fitted in its place, followed the raw angle better beyond
    the recording's fluctuation. The named effect does not beat another library effect on
    the raw signal, so nothing is named: `unexplained`, gravity reported apart."""
    spec = cs.CaseSpec("pressure_stiffening", "pi_steps", 0, "evident", family="overdamped", rate_hz=500.0,
                       strength=0.3)
    d = diagnosed(*cs.write(cs.build(spec), tmp_path))
    assert d.rival is not None and d.rival.better, d.warnings
    assert d.verdict == "unexplained" and d.effects == [], d.warnings
    assert list(d.rival.named) == [e.name for e in d.partial_effects][:len(d.rival.named)]
    assert report_failures(d) == []


def test_a_rival_the_raw_angle_finds_worse_does_not_stand() -> None:
    """Worse beyond the recording's fluctuation and outside the raw angle's tie (1.3 times
    the named model's error and the noise): the named model keeps `complete`."""
    critical = _rival(0.39, z=0.0).difference.critical
    assert not _rival(0.39, z=critical + 0.1).stands
    assert _rival(0.39, z=critical - 0.1).stands


def test_a_rival_worse_by_the_test_but_within_the_tie_stands() -> None:
    """Within 2 % of the named model's raw error, or both at the noise: a reliable difference
    that small does not make the named effects the physics, so the rival stands, and the
    sentence says it is reliably less close."""
    critical = _rival(0.301, z=0.0).difference.critical
    share = _rival(0.405, z=critical + 1.0, named_raw_deg=0.40)  # 1.25 % more, the noise 0.30
    assert share.stands and share.worse and share.tied
    assert "(within 2 %), if reliably less closely" in share.sentence()
    noise = _rival(0.37, z=critical + 1.0, named_raw_deg=0.33)  # 12 % more, both within 1.25 × 0.30
    assert noise.stands and "both within 1.25 times the sensor's noise" in noise.sentence()
    assert not _rival(0.38, z=critical + 1.0, named_raw_deg=0.33).stands  # 0.38 > 1.25 × 0.30


def test_a_rival_that_would_not_be_named_does_not_stand() -> None:
    """A rival the search would not name (short of ΔBIC, held-out data, pinned at a bound) is
    no alternative the recording offers: where the plain model ties with the name,
    raw_error's own judgement speaks, not this one."""
    assert not _rival(0.29, z=-3.0, significant=False).stands


def test_a_rival_already_searched_or_in_the_model_is_not_fitted_again() -> None:
    assert rivals_to_try([], {}) == list(RIVALS)
    assert "pressure_stiffening" not in rivals_to_try(["pressure_stiffening"], {})
    assert "creep" not in rivals_to_try([], {"creep": {"stiffness_ratio": 0.2}})


def test_its_sentence_passes_the_sentence_checks() -> None:
    facts = Facts(200.0, 0.01, True, 3.0, None, 4000)
    for rival in (_rival(0.301, 0.3), _rival(0.25, -2.5), _rival(0.33, 1.2), _rival(0.31, 0.5, loop=True)):
        assert failures(rival.sentence(), facts) == [], rival.sentence()
        assert failures(f"warning: {rival.sentence()}", facts) == []


def _stiffening_finger(tmp_path: Path) -> tuple[Path, Path]:
    """The independent truth's finger whose chamber pressure stiffens it, steps through a
    ringing finger at 500 Hz, 3.2 times the sensor's noise."""
    spec = cs.CaseSpec("pressure_stiffening", "steps", 0, "evident", family="ringing", rate_hz=500.0,
                       strength=0.09442335726225226)
    case = cs.build(spec)
    assert case.visibility > 3.0, case.visibility
    return cs.write(case, tmp_path)


def _hysteretic_finger(tmp_path: Path) -> tuple[Path, Path]:
    spec = cs.CaseSpec("hysteresis", "prbs", 1, "evident", family="overdamped", rate_hz=200.0)
    case = cs.build(spec)
    assert case.visibility > 3.0, case.visibility
    return cs.write(case, tmp_path)


def _eight(also: object) -> list[str]:
    """The library's effects the default search fits whatever the screen says."""
    from hand_service.config import effects as fx
    from hand_service.diagnose import requested

    return [name for name in requested.searched(()) if not fx.BY_NAME[name].admitted_by_screen]


def test_a_stiffening_finger_named_gravity_is_not_graded_complete(tmp_path: Path, monkeypatch) -> None:
    """The eight alone searched (the default's ground, whatever else it searches behind the
    screen) name `gravity`, which followed the recording to its noise and was graded
    `complete` (docs/results.md §12.36, §12.40). Fitted in its place, the stiffening follows the raw
    angle better: the grade is not `complete`, the rival is said, and every sentence passes
    the checks."""
    monkeypatch.setattr("hand_service.diagnose.engine.searched", _eight)
    d = diagnosed(*_stiffening_finger(tmp_path))
    assert d.verdict == "missing_physics", d.warnings
    assert d.grade == "dominant", d.warnings
    assert d.rival is not None and d.rival.name == "pressure_stiffening", d.warnings
    assert d.rival.rival_raw_deg < d.rival.named_raw_deg and not d.rival.worse
    assert d.rival.named == tuple(e.name for e in d.effects)
    assert d.structure_left == d.rival.sentence() and d.rival.sentence() in d.warnings
    assert d.to_json()["rival"]["in_place_of"] == list(d.rival.named)
    assert report_failures(d) == []


@pytest.mark.thorough
def test_a_hysteretic_finger_named_gravity_and_a_cubic_spring_is_not_graded_complete(tmp_path: Path,
                                                                                    monkeypatch) -> None:
    """The independent truth's finger whose material holds a loop (Bouc-Wen, not the library's
    Dahl), a PRBS through an over-damped finger at 200 Hz, 4.8 times the sensor's noise: the
    default search names `hysteresis` (test_default_names_the_loop, below); the eight alone
    (the default's ground) name `gravity` and `cubic_stiffness`, which follow the recording to
    its noise, and no library rival stands (docs/results.md §12.42). The simulator's loop,
    fitted in their place, gains on the plain model, holds a loop's memory, and the raw angle
    cannot tell it from them: the grade is not `complete`, the loop is said as the library's
    hysteresis form, and every sentence passes the checks."""
    monkeypatch.setattr("hand_service.diagnose.engine.searched", _eight)
    d = diagnosed(*_hysteretic_finger(tmp_path))
    assert d.verdict == "missing_physics", d.warnings
    assert [e.name for e in d.effects] == ["gravity", "cubic_stiffness"], d.warnings
    assert d.grade == "dominant", d.warnings
    assert d.rival is not None and d.rival.name == "hysteresis_loop" and d.rival.loop, d.warnings
    assert not d.rival.worse and d.rival.difference.n > 0
    assert d.to_json()["rival"]["loop"] is True
    assert "Dahl's form, the library's hysteresis" in d.structure_left
    assert report_failures(d) == []


@pytest.mark.thorough  # the loop by default: make test keeps the outside recording's
def test_default_names_the_loop_and_no_loop_rival_beside_it(tmp_path: Path) -> None:
    """The same finger under the default search: `hysteresis` is named, and no Dahl loop is
    fitted in its place as a rival (the named model holds one)."""
    d = diagnosed(*_hysteretic_finger(tmp_path))
    assert [e.name for e in d.effects] == ["hysteresis"], d.warnings
    assert d.rival is None or d.rival.name != "hysteresis_loop", d.warnings
    assert report_failures(d) == []


def test_behind_the_screen_the_stiffening_is_named_first_where_it_beats_gravity_on_the_raw_angle(
        tmp_path: Path, monkeypatch) -> None:
    """The same stiffened finger with the stiffening searched behind the screen (kept only where
    its model follows the raw angle closer than the eight's: search/admission.py; searched so
    by default it stood in for a contact, docs/results.md §12.57): `pressure_stiffening` is
    named first, where the eight alone said `gravity`."""
    from tests.diagnose.test_other_first import stiffening_behind_the_screen

    stiffening_behind_the_screen(monkeypatch)
    d = diagnosed(*_stiffening_finger(tmp_path))
    assert d.verdict == "missing_physics", d.warnings
    assert [e.name for e in d.effects][:1] == ["pressure_stiffening"], d.warnings
