"""Every real-rig fixture (tests/diagnose/real/README.md §1 and §6): it loads, its expectation
was written down, and (slow) `diagnose` is never confidently wrong on it.

A confident wrong verdict is a library effect named with grade `complete` or `dominant` that
the rig's written expectation does not allow; a negative control must come out `unexplained`
or `insufficient_excitation`. The judging is tests/diagnose/real/table.py's, the same that
makes the README's table.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from hand_service.config.profile import load_model
from hand_service.recording import read_recording
from tests.diagnose.real.odefit import read_csv
from tests.diagnose.real.rigs import RIGS
from tests.diagnose.real.table import (
    FIXTURES,
    HERE,
    LIBRARY_EFFECTS,
    Expectation,
    expectation,
    judge,
    lower_rate,
    our_raw_rms,
    run_diagnose,
)

REAL = HERE
LOWER_RATE = {rig: lower_rate(read_csv(REAL / f"{rig}.csv"))[0] for rig in FIXTURES}
TWO_RATES = sorted(rig for rig, rate in LOWER_RATE.items() if rate is not None)
RUNS = [(rig, None) for rig in FIXTURES] + [(rig, LOWER_RATE[rig]) for rig in TWO_RATES]
Cache = dict[tuple[str, float | None], dict[str, Any]]


def test_every_rig_of_the_converter_is_a_fixture() -> None:
    assert {rig.name for rig in RIGS} <= set(FIXTURES)
    assert len(FIXTURES) >= 10


@pytest.mark.parametrize("rig", FIXTURES)
def test_fixture_loads_with_its_expectation(rig: str) -> None:
    csv = REAL / f"{rig}.csv"
    assert csv.stat().st_size < 300_000
    recording = read_recording(csv)
    assert recording.duration_s >= 2.0 and len(recording.t_s) >= 200
    assert {"source", "scaling", "sample_rate_hz"} <= set(recording.metadata)
    assert np.ptp(recording.angle_deg) > 1.0 and np.ptp(recording.pressure_kpa) > 0.0
    assert math.isclose(float(recording.metadata["sample_rate_hz"]),
                        1.0 / float(np.median(np.diff(recording.t_s))), rel_tol=1e-3)
    model = load_model(REAL / f"{rig}_model.yaml")
    assert model.stiffness_nm_per_rad > 0 and model.pressure_gain_nm_per_kpa > 0
    assert model.damping_nms_per_rad >= 0
    exp = expectation(rig)
    assert exp.kind in ("missing_physics", "no_library_effect", "negative_control")
    assert set(exp.acceptable_effects) <= LIBRARY_EFFECTS
    if exp.kind == "negative_control":
        assert exp.control in ("no_authority", "unlogged_input", "outside_library")
        assert set(exp.acceptable_verdicts) <= {"unexplained", "insufficient_excitation"}
        assert exp.effect is None
    if exp.kind == "missing_physics":
        assert exp.effect in exp.acceptable_effects
    mine = read_csv(csv)  # the converter's fitter read exactly what diagnose reads
    assert np.allclose(mine.t, recording.t_s) and np.allclose(mine.theta_deg, recording.angle_deg)


def test_the_brief_of_issue_44_is_met_by_the_fixtures() -> None:
    """At least 8 rigs beyond Silverbox and EMPS, 3 negative controls of the three kinds."""
    new = [rig for rig in FIXTURES if rig not in ("silverbox", "emps")]
    assert len(new) >= 8
    controls = {expectation(rig).control for rig in new if expectation(rig).kind == "negative_control"}
    assert {"no_authority", "unlogged_input", "outside_library"} <= controls


def test_the_judge_flags_what_it_should() -> None:
    exp = Expectation("negative_control", None, (), ("unexplained", "insufficient_excitation"),
                      "no_authority")
    wrong = judge(exp, {"verdict": "missing_physics", "grade": "complete",
                        "effects": [{"name": "pressure_deadzone"}]})
    assert wrong.confident_wrong and wrong.control_failed
    weak = judge(exp, {"verdict": "parameters_only", "grade": None, "effects": []})
    assert not weak.confident_wrong and weak.control_failed
    dryer = Expectation("missing_physics", "dead_time", ("dead_time", "valve_lag"),
                        ("missing_physics", "insufficient_excitation"), None)
    right = judge(dryer, {"verdict": "missing_physics", "grade": "dominant",
                          "effects": [{"name": "valve_lag"}]})
    assert not right.confident_wrong and right.verdict_ok
    other = judge(dryer, {"verdict": "missing_physics", "grade": "dominant",
                          "effects": [{"name": "dead_time"}, {"name": "gravity"}]})
    assert other.confident_wrong


def test_some_fixture_is_run_at_two_rates() -> None:
    assert "emps" in TWO_RATES


@pytest.fixture(scope="module")
def diagnoses() -> Cache:
    """diagnose's JSON per (rig, decimation), filled lazily: each run is made once per module."""
    return {}


def diagnosed(cache: Cache, rig: str, rate: float | None,
              workdir: Path) -> dict[str, Any]:
    if (rig, rate) not in cache:
        cache[rig, rate] = run_diagnose(rig, rate, workdir)
    return cache[rig, rate]


@pytest.mark.slow
@pytest.mark.parametrize(("rig", "rate"), RUNS)
def test_diagnose_is_never_confidently_wrong(rig: str, rate: float | None, tmp_path: Path,
                                             diagnoses: Cache) -> None:
    verdict = judge(expectation(rig), diagnosed(diagnoses, rig, rate, tmp_path))
    assert not verdict.confident_wrong, verdict
    assert not verdict.control_failed, verdict


# rawcheck's figure has no offset at all; diagnose's, a constant one per model. On EMPS, a
# springless axis, the two disagree (docs/results.md §12.8): offset-free, the named friction
# leaves the raw error larger than the nominal's.
OFFSET_FREE_DISAGREES = pytest.mark.xfail(strict=True, reason="EMPS: offset-free, the augmented "
                                          "model misses the raw angle by more than the nominal")
RAW_RUNS = [pytest.param(rig, rate, marks=OFFSET_FREE_DISAGREES) if rig == "emps" else (rig, rate)
            for rig, rate in RUNS]


@pytest.mark.slow
@pytest.mark.parametrize(("rig", "rate"), RAW_RUNS)
def test_a_named_effect_lowers_the_raw_error(rig: str, rate: float | None, tmp_path: Path,
                                             diagnoses: Cache) -> None:
    """Issue 44: named only when the model with it, simulated from the command alone, misses
    the raw angle by less than the model without it (rawcheck.py measures both)."""
    result = diagnosed(diagnoses, rig, rate, tmp_path)
    raw = our_raw_rms(rig, rate, result)
    if not result.get("effects") or raw["augmented"] is None:
        pytest.skip("no effect named, or none rawcheck can simulate")
    assert raw["augmented"] < raw["nominal"], raw


@pytest.mark.slow
@pytest.mark.parametrize("rig", TWO_RATES)
def test_verdict_class_does_not_change_with_the_rate(rig: str, tmp_path: Path,
                                                     diagnoses: Cache) -> None:
    native = diagnosed(diagnoses, rig, None, tmp_path)["verdict"]
    assert diagnosed(diagnoses, rig, LOWER_RATE[rig], tmp_path)["verdict"] == native
