"""Recordings an outside probe's own generator made (tests/diagnose/outside/README.md: its
physics, sensor and expected answer, written before diagnose ran): each one's verdict, and
every sentence of its report true of it."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.diagnose.checked import diagnosed, report_failures

OUTSIDE = Path(__file__).resolve().parent / "outside"


def _diagnosed(name: str) -> dict:
    """The recording `name` diagnosed with its model as `hand-service diagnose` reads them,
    every printed sentence true of it (tests/diagnose/checked.py); its JSON."""
    d = diagnosed(OUTSIDE / f"{name}.csv", OUTSIDE / f"{name}.yaml")
    assert report_failures(d) == []
    return d.to_json()


def test_a_spring_stiffening_faster_than_the_cube_on_a_one_way_ramp_is_named_a_cubic_spring() -> None:
    """c·(sinh(aθ) − aθ) from 0° to 90°: the cubic spring and gravity beside it fit, gravity's
    halves disagree; the cubic alone holds across the postures and is named, gravity is
    reported apart."""
    result = _diagnosed("sinh_spring_ramp")
    named = [e["name"] for e in result["effects"]]
    assert named == ["cubic_stiffness"], (result["verdict"], result["warnings"])
    assert result["verdict"] == "missing_physics"
    assert "gravity" in [e["name"] for e in result["partial_effects"]]
    assert any("gravity does not hold across the recording's postures" in w for w in result["warnings"])


@pytest.mark.thorough
def test_a_stiff_object_met_past_45_degrees_is_named_a_contact_there() -> None:
    """An object five times as stiff as the finger, met past 45° on steps: the default search
    (contact behind the screen, searched again from the residual's onset) names a contact
    within 2° of the object."""
    result = _diagnosed("stiff_contact_steps")
    assert [e["name"] for e in result["effects"]] == ["contact"], result["verdict"]
    assert abs(result["effects"][0]["params"]["onset_deg"] - 45.0) < 2.0


@pytest.mark.thorough  # make test keeps the onset located on a slow sine (test_onset.py)
def test_a_stiff_object_met_past_45_degrees_is_located_not_named_gravity(monkeypatch) -> None:
    """The same object with the eight alone searched: gravity fitted it with k at a third of
    the nominal and was named. Its slope over the range is many times k, so the onset is
    fitted in full: it wins, within 2° of the object."""
    from hand_service.config import effects as fx
    from hand_service.diagnose import requested

    monkeypatch.setattr("hand_service.diagnose.engine.searched", lambda also: [
        name for name in requested.searched(()) if not fx.BY_NAME[name].admitted_by_screen])
    result = _diagnosed("stiff_contact_steps")
    assert result["verdict"] == "unexplained" and result["effects"] == [], result["verdict"]
    onset = result["onset"]
    assert onset is not None and onset["compared"] == "fitted" and onset["side"] == "above"
    assert abs(onset["angle_deg"] - 45.0) < 2.0
    assert any("switches on above" in w for w in result["warnings"])


def test_a_loop_in_the_angle_is_hysteresis_not_dry_friction() -> None:
    """A Bouc–Wen loop (±0.1 N·m, turning over within about 2.9° of travel) on a slow ramp:
    dry friction was named for it. The loop fitted in full in its place wins, and its travel
    is a loop's, not a friction's: outside the library, with the travel and the torque."""
    result = _diagnosed("boucwen_ramp")
    assert result["verdict"] == "unexplained" and result["effects"] == [], result["verdict"]
    loop = result["hysteresis"]
    assert loop is not None and loop["delta_bic"] > 10.0 and loop["memory_delta_bic"] > 10.0, loop
    assert 1.5 < loop["travel_deg"] < 6.0 and abs(loop["torque_nm"] / 0.1 - 1.0) < 0.3, loop
    assert any("hysteresis is outside the library" in w for w in result["warnings"])


@pytest.mark.thorough
def test_a_backlash_on_steps_is_a_play_before_the_sensor_not_dry_friction() -> None:
    """A play of 3° in all between the finger and its sensor, on steps: dry friction was named
    for it, `dominant` (both leave the angle short of the spring's line, on the side it came
    from). The play fitted in friction's place follows the raw angle three times closer, at
    its true width: outside the library."""
    result = _diagnosed("backlash_steps")
    assert result["verdict"] == "unexplained" and result["effects"] == [], result["verdict"]
    assert "coulomb_friction" in [e["name"] for e in result["partial_effects"]]
    play = result["play"]
    assert play is not None and abs(play["half_width_deg"] - 1.5) < 0.15, play
    assert play["raw_rmse_deg"] <= 0.5 * play["named_raw_rmse_deg"], play
    assert any("backlash is outside the library" in w for w in result["warnings"])


@pytest.mark.thorough
def test_a_gain_saturating_with_pressure_is_not_named_gravity_and_a_cubic_spring() -> None:
    """N·p/(1 + p/1000 kPa) under a multisine: gravity and a cubic spring bend the static map
    as the saturating gain does and were named, `dominant` (structure left). The stiffening
    with pressure (on request), fitted in their place, follows the raw angle closer beyond
    the recording's fluctuation: nothing is named."""
    result = _diagnosed("saturating_gain_multisine")
    assert result["verdict"] == "unexplained" and result["effects"] == [], result["verdict"]
    rival = result["rival"]
    assert rival is not None and rival["name"] == "pressure_stiffening" and rival["better"], rival
    assert rival["raw_rmse_deg"] < rival["named_raw_rmse_deg"]
    assert "gravity" in [e["name"] for e in result["partial_effects"]]
