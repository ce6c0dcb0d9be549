"""Every sentence diagnose prints is true of the recording
(hand_service/diagnose/report/sentence_checks.py): the checks catch the false sentences real
rigs got, and the fixtures' (the outside recordings' in test_outside_recordings.py) and a
slice of the battery's reports pass them unscreened; (slow)
every real fixture's and every case of the full battery's report too."""

from __future__ import annotations

import dataclasses
import json
import re
from pathlib import Path

import numpy as np
import pytest

from hand_service.config.profile import load_model
from hand_service.diagnose.engine import diagnose
from hand_service.diagnose.recording.response_onset import onset_delay_s
from hand_service.diagnose.recording.timebase import regular_grid
from hand_service.diagnose.report.evidence import uncertainty
from hand_service.diagnose.report.sentence_checks import Facts, failures
from hand_service.recording import read_recording
from tests.diagnose.checked import diagnosed, report_failures
from tests.diagnose.real.table import FIXTURES as REAL_RIGS
from tests.diagnose.truth import cases as cs
from tests.diagnose.truth.battery import specs

HERE = Path(__file__).parent
RINGING = Facts(rate_hz=100.0, onset_s=0.01, rings=True, own_hz=9.5, period_s=None, n_fit=2000,
                held_ratio={"damping_nms_per_rad": 2.31, "stiffness_nm_per_rad": 1.1})
OVERDAMPED_25HZ = Facts(rate_hz=25.0, onset_s=None, rings=False, own_hz=0.007, period_s=None, n_fit=900)


@pytest.mark.parametrize(("text", "facts"), [
    ("the finger starts to move about 157.0 ms later after each change of pressure", RINGING),
    ("add content near the finger's resonance (4.3 Hz) and 0 % above", OVERDAMPED_25HZ),
    ("lies 10 % near the finger's resonance (30 Hz) and 0 % above", RINGING),
    ("add content near 8 Hz (steps, or a chirp through it)", OVERDAMPED_25HZ),
    ("the command repeats at 0.022 Hz with nearly all its power at that one frequency", RINGING),
    ("the recording alone cannot pin the plain parameters (stiffness_nm_per_rad ±498469 % from the data "
     "alone): they are held near the nominal (a prior of ±25 %)", RINGING),
    ("it holds damping_nms_per_rad near the nominal", RINGING),
    ("stiffness_nm_per_rad              0.57        0.42  ± 15", RINGING),
    ("warning: cubic_stiffness reduce the residual, but a structured residual remains", RINGING),
    ("windows (s): -0.00-0.30, 1.20-1.50", RINGING),
    # an outside probe's backlash (outside/backlash_prbs.csv), its verdict `unexplained`
    ("warning: structure is left beside the effects found, and quadratic_damping explains less of the "
     "recorded angle than all that is left; dead_time, coulomb_friction, fitted again without it, each "
     "explain more than what is left (…), so they are named", RINGING),
])
def test_the_false_sentences_real_rigs_got_are_caught(text: str, facts: Facts) -> None:
    assert failures(text, facts), text


@pytest.mark.parametrize(("text", "facts"), [
    ("the finger starts to move about 40.0 ms later after each change of pressure",
     Facts(100.0, 0.05, True, 9.5, None, 2000)),
    ("lies 10 % near the finger's resonance (9.5 Hz) and 0 % above", RINGING),
    ("the command repeats at 0.1 Hz with nearly all its power", Facts(100.0, None, True, 9.5, 10.2, 2000)),
    ("stiffness_nm_per_rad              0.57        0.42  ± 15 (unknown: over 100 % of the value)", RINGING),
    ("the recording alone cannot pin damping_nms_per_rad (unknown from the data alone): the nominal's "
     "uncertainty (a prior of ±25 %) is added to the fit, which holds stiffness_nm_per_rad near the nominal",
     RINGING),
    ("warning: cubic_stiffness reduces the residual", RINGING),
    ("windows (s): 0.00 to 0.30, 1.20 to 1.50", RINGING),
    ("dead_time and valve_lag could not be told apart at first; …, so it is named",
     dataclasses.replace(RINGING, named=("dead_time",))),
])
def test_true_sentences_pass(text: str, facts: Facts) -> None:
    assert failures(text, facts) == []


def test_an_uncertainty_only_its_printed_digits_make_larger_says_unknown() -> None:
    """A std of 0.01098 beside a value of 0.010983 prints as ± 0.011: over the value as
    printed, so the report says it is unknown (two battery reports did not)."""
    assert failures("0.010983 ± 0.011", RINGING)
    text = f"0.010983 {uncertainty(0.01098, value=0.010983)}"
    assert "unknown" in text and failures(text, RINGING) == []
    assert "unknown" not in uncertainty(0.0104, value=0.010983)


def test_the_onset_is_measured_from_the_data() -> None:
    """Steps through a first-order finger that answers 120 ms late: the onset is measured at
    the delay, within two samples."""
    rate, delay = 200.0, 24
    command = np.repeat([0.0, 50.0, 10.0, 60.0], 400)
    angle = np.zeros(command.size)
    for i in range(1, command.size):
        angle[i] = angle[i - 1] + 0.1 * (command[max(i - delay, 0)] - angle[i - 1])
    angle += np.random.default_rng(0).normal(0.0, 0.05, angle.size)
    onset = onset_delay_s(command, angle, rate)
    assert onset is not None and abs(onset - delay / rate) <= 2.0 / rate, onset


# the outside recordings with a verdict to check run these checks in their own tests
# (test_outside_recordings.py); the backlash on a PRBS and the real EMPS rig (make test
# diagnoses it in test_real_rigs.py) in test-thorough
FIXTURES = [pytest.param("outside", "backlash_prbs", marks=pytest.mark.thorough),
            pytest.param("real", "emps", marks=pytest.mark.thorough)]


@pytest.mark.parametrize(("folder", "name"), FIXTURES)
def test_every_fixture_report_passes_the_checks(folder: str, name: str) -> None:
    base = HERE / folder
    model = base / (f"{name}_model.yaml" if folder == "real" else f"{name}.yaml")
    hold = "zoh"
    if folder == "real":
        hold = json.loads((base / f"{name}_expected.json").read_text())["input_hold"]
    assert report_failures(diagnosed(base / f"{name}.csv", model, hold)) == []


# the real rigs the cheap test above leaves out (Silverbox's 12 200 samples: its own test, below)
OTHER_RIGS = [rig for rig in REAL_RIGS if rig not in ("emps", "silverbox")]


@pytest.mark.slow
@pytest.mark.parametrize("rig", OTHER_RIGS)
def test_every_real_rig_report_passes_the_checks(rig: str) -> None:
    test_every_fixture_report_passes_the_checks("real", rig)


@pytest.mark.slow  # with the other rigs': the longest of test-thorough, which .ci/run's 25 minutes hold
def test_the_silverbox_report_passes_the_checks() -> None:
    base = HERE / "real"
    hold = json.loads((base / "silverbox_expected.json").read_text())["input_hold"]
    assert report_failures(diagnosed(base / "silverbox.csv", base / "silverbox_model.yaml", hold)) == []


# the two costliest (a concealed lag at 200 Hz, dry friction at 500 Hz) in test-thorough
BATTERY_SLICE = [
    cs.CaseSpec("dead_time", "steps", 0, "evident", "ringing", 100.0),
    pytest.param(cs.CaseSpec("valve_lag", "chirp", 1, "concealed", "overdamped", 200.0),
                 marks=pytest.mark.thorough),
    pytest.param(cs.CaseSpec("coulomb_friction", "ramp", 0, "evident", "stiff", 500.0),
                 marks=pytest.mark.thorough),
    cs.CaseSpec(cs.CLEAN, "slow_sine", 0, "none", "overdamped", 100.0),
    cs.CaseSpec("contact", "steps", 0, "evident", "ringing", 100.0),
]


@pytest.mark.parametrize("spec", BATTERY_SLICE, ids=lambda s: s.id)
def test_battery_reports_pass_the_checks(spec: cs.CaseSpec, tmp_path: Path) -> None:
    recording, model = cs.write(cs.build(spec), tmp_path)
    assert report_failures(diagnosed(recording, model)) == []


@pytest.mark.slow
def test_a_searched_contact_report_passes_the_checks_and_gives_its_spring_torque(tmp_path: Path) -> None:
    """A contact searched for and named says what the recording fixes: its spring's torque
    at the deepest angle reached, in N·m, beside K (which trades with n)."""
    recording, model = cs.write(cs.build(cs.CaseSpec("contact", "steps", 1, "evident")), tmp_path)
    rec = read_recording(recording, None)
    grid = regular_grid(rec.t_s, rec.pressure_kpa, rec.angle_deg, recording)
    d = diagnose(load_model(model, None), grid.t_s, grid.pressure_kpa, grid.angle_deg, grid.rate_hz,
                 missing=grid.missing, also=("contact",))
    assert [e.name for e in d.effects][:1] == ["contact"]
    assert re.search(r"the spring's torque at the deepest angle reached \(\d+\.\d°\) = \S+ ± \S+ N·m",
                     d.effects[0].evidence), d.effects[0].evidence
    assert report_failures(d) == []


@pytest.mark.slow
@pytest.mark.parametrize("spec", specs(), ids=lambda s: s.id)
def test_every_battery_report_passes_the_checks(spec: cs.CaseSpec, tmp_path: Path) -> None:
    """The full battery (`python -m tests.diagnose.truth.battery`'s default cases), each
    report through the checks."""
    test_battery_reports_pass_the_checks(spec, tmp_path)
