"""The rival before the grade `complete` (search/rival_check.py): an effect searched only on
request, fitted in place of the named ones, that would be named had it been searched and
follows the raw angle as well (within raw_error.TIE_SHARE, or both at the noise) or better
keeps the grade from `complete`, and is said."""

from __future__ import annotations

from pathlib import Path

from hand_service.diagnose.fitting.raw_error import TIE_NOISE, TIE_SHARE
from hand_service.diagnose.report.sentence_checks import Facts, failures
from hand_service.diagnose.search.rival_check import RIVALS, Rival, rivals_to_try
from tests.diagnose.test_sentence_checks import _diagnosed, _report_failures
from tests.diagnose.truth import cases as cs


def _rival(rival_raw_deg: float, named_raw_deg: float = 0.30, significant: bool = True,
           noise_deg: float = 0.30) -> Rival:
    return Rival("pressure_stiffening", ("gravity",), {"gain": 0.42}, 120.0, significant, rival_raw_deg,
                 named_raw_deg, noise_deg)


def test_a_tie_on_the_raw_angle_stands() -> None:
    tie = _rival(0.30 * (1.0 + 0.5 * TIE_SHARE))
    assert tie.stands and not tie.better
    assert "cannot tell them apart" in tie.sentence()
    assert "the grade is not complete" in tie.sentence()


def test_a_better_rival_stands_and_says_so() -> None:
    better = _rival(0.30 * (1.0 - 2.0 * TIE_SHARE))
    assert better.stands and better.better
    assert "better than the model with gravity" in better.sentence()
    assert better.to_json()["better"] is True


def test_a_worse_rival_stands_only_where_both_follow_to_the_noise() -> None:
    worse = 0.30 * (1.0 + 2.0 * TIE_SHARE)
    assert not _rival(worse, noise_deg=0.30 / TIE_NOISE).stands  # the rival past the noise's tie
    at_noise = _rival(worse, noise_deg=0.30)
    assert at_noise.stands and not at_noise.better
    assert "fits to the noise too" in at_noise.sentence() and "if less closely" in at_noise.sentence()
    assert not _rival(0.42, named_raw_deg=0.40, noise_deg=0.30).stands  # the named model past it too


def test_a_rival_that_would_not_be_named_does_not_stand() -> None:
    """A rival the search would not name (short of ΔBIC, held-out data, pinned at a bound) is
    no alternative the recording offers: where the plain model ties with the name,
    raw_error's own judgement speaks, not this one."""
    assert not _rival(0.29, significant=False).stands


def test_a_rival_already_searched_or_in_the_model_is_not_fitted_again() -> None:
    assert rivals_to_try([], {}) == list(RIVALS)
    assert "pressure_stiffening" not in rivals_to_try(["pressure_stiffening"], {})
    assert "creep" not in rivals_to_try([], {"creep": {"stiffness_ratio": 0.2}})


def test_its_sentence_passes_the_sentence_checks() -> None:
    facts = Facts(200.0, 0.01, True, 3.0, None, 4000)
    for rival in (_rival(0.301), _rival(0.25), _rival(0.33)):
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


def test_a_stiffening_finger_named_gravity_is_not_graded_complete(tmp_path: Path, monkeypatch) -> None:
    """The eight alone searched (the default's ground, whatever else it searches behind the
    screen) name `gravity`, which followed the recording to its noise and was graded
    `complete` (docs/results.md §12.36, §12.40). Fitted in its place, the stiffening follows the raw
    angle better: the grade is not `complete`, the rival is said, and every sentence passes
    the checks."""
    from hand_service.config import effects as fx
    from hand_service.diagnose import requested

    def eight(also: object) -> list[str]:
        return [name for name in requested.searched(()) if not fx.BY_NAME[name].admitted_by_screen]

    monkeypatch.setattr("hand_service.diagnose.engine.searched", eight)
    d = _diagnosed(*_stiffening_finger(tmp_path))
    assert d.verdict == "missing_physics", d.warnings
    assert d.grade == "dominant", d.warnings
    assert d.rival is not None and d.rival.name == "pressure_stiffening" and d.rival.better, d.warnings
    assert d.rival.named == tuple(e.name for e in d.effects)
    assert d.structure_left == d.rival.sentence() and d.rival.sentence() in d.warnings
    assert d.to_json()["rival"]["in_place_of"] == list(d.rival.named)
    assert _report_failures(d) == []
