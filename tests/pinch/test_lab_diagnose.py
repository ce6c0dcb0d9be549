"""The lab's diagnose on the mismatched plant (hand_service.pinch.lab_diagnose): on valves
within the library it names the silicone's loop at about its size, and the controller that
runs the model diagnose writes renders the set stiffness where the calibrated one does not;
the board's slow vent hides the loop from it unless the valve fit takes the vent's lag apart."""

from __future__ import annotations

import math
import tempfile
from pathlib import Path

import numpy as np
import pytest

from hand_service.api.impedance import gain_limits
from hand_service.config.profile import Profile
from hand_service.pinch.bode import rendered
from hand_service.pinch.lab_diagnose import (
    EVEN_VALVES,
    LabDiagnosis,
    diagnosed_controller,
    free_run,
    lab_diagnosis,
    step_command_kpa,
)
from hand_service.pinch.mismatch import NONE, PAPER_MISMATCH, identify_on_plant


@pytest.fixture(scope="module")
def calibrated(truth: Profile) -> Profile:
    """The lab's calibrate sensor and gain on the mismatched plant with even valves."""
    with tempfile.TemporaryDirectory() as scratch:
        return identify_on_plant(truth, truth, EVEN_VALVES, 1, Path(scratch))


@pytest.fixture(scope="module")
def diagnosed(truth: Profile, calibrated: Profile) -> tuple[Profile, LabDiagnosis]:
    """After them, the lab's calibrate valve and diagnose on the index finger."""
    controller, (found,) = diagnosed_controller(truth, calibrated, EVEN_VALVES, 1, ["index"])
    return controller, found


def test_the_free_run_of_the_plain_plant_settles_where_the_prbm_does(truth: Profile) -> None:
    """Without a mismatch, each held step ends at N p / k (the profile's valve, no effects)."""
    finger = truth.finger("index")
    command = step_command_kpa(finger)
    angle_deg, chamber_kpa = free_run(finger, NONE, command)
    m = finger.model
    ends = np.flatnonzero(np.diff(command) != 0.0)  # the last sample of each held level
    expected = np.degrees(m.pressure_gain_nm_per_kpa * command[ends] / m.stiffness_nm_per_rad)
    np.testing.assert_allclose(angle_deg[ends + 1], expected, atol=0.05)
    np.testing.assert_allclose(chamber_kpa[ends + 1], command[ends], atol=0.05)


Diagnosed = tuple[Profile, LabDiagnosis]


def test_diagnose_names_the_loop_on_valves_within_the_library(truth: Profile, diagnosed: Diagnosed) -> None:
    controller, found = diagnosed
    named = {e.name: e.params for e in found.diagnosis.effects}
    k = truth.finger("index").model.stiffness_nm_per_rad
    true_torque_nm = k * math.radians(EVEN_VALVES.hysteresis_deg)
    assert found.diagnosis.verdict == "missing_physics"
    assert named["hysteresis"]["torque_nm"] == pytest.approx(true_torque_nm, rel=0.25)
    assert found.valve_lag_tau_s == pytest.approx(EVEN_VALVES.valves.fill_tau_of("index"), rel=0.1)
    assert controller.finger("index").model.effects["hysteresis"] == named["hysteresis"]  # what it writes


def test_the_diagnosed_controller_renders_the_set_stiffness(truth: Profile, calibrated: Profile,
                                                            diagnosed: Diagnosed) -> None:
    k_set = gain_limits(truth.finger("index").model)[0]
    got = {name: rendered(truth, c, "index", k_set, 0.5, mismatch=EVEN_VALVES).stiffness_n_per_deg / k_set
           for name, c in (("calibrated", calibrated), ("diagnosed", diagnosed[0]))}
    assert abs(got["diagnosed"] - 1.0) < 0.10
    assert got["calibrated"] - 1.0 > 0.15  # the loop read as contact force


def test_the_boards_slow_vent_hides_the_loop_unless_the_valve_fit_takes_it_apart(truth: Profile) -> None:
    """One lag for both directions lands between the fill's and the vent's and hides the loop;
    the vent's own lag (valve_vent_lag) recovers both lags, and diagnose names the loop."""
    with tempfile.TemporaryDirectory() as scratch:
        lab = identify_on_plant(truth, truth, PAPER_MISMATCH, 1, Path(scratch))
    valves = PAPER_MISMATCH.valves
    assert valves is not None
    fill_s = valves.fill_tau_of("index")
    one = lab_diagnosis(truth.finger("index"), lab.finger("index"), PAPER_MISMATCH,
                        np.random.default_rng(1), 0.3, 0.5, vent=False)
    assert "hysteresis" not in {e.name for e in one.diagnosis.effects}
    assert fill_s * 1.5 < one.valve_lag_tau_s < fill_s * valves.vent_over_fill / 1.5
    apart = lab_diagnosis(truth.finger("index"), lab.finger("index"), PAPER_MISMATCH,
                          np.random.default_rng(1), 0.3, 0.5)
    assert apart.valve_lag_tau_s == pytest.approx(fill_s, rel=0.05)
    assert apart.valve_vent_tau_s == pytest.approx(fill_s * valves.vent_over_fill, rel=0.05)
    assert "hysteresis" in {e.name for e in apart.diagnosis.effects}
    written = apart.diagnosis.refit_model().effects
    assert written["valve_vent_lag"]["tau_s"] == pytest.approx(apart.valve_vent_tau_s)
