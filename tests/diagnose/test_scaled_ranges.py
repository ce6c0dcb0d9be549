"""Effect ranges scaled to the recording (Param.effect): proven on recordings of the
independent truth generator (tests/diagnose/truth/) that the library's fixed ranges got
wrong."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from hand_service.config import effects as fx
from hand_service.diagnose.model.params import EffectScales, Param
from tests.diagnose.truth import cases as cs
from tests.diagnose.truth.battery import diagnose_argv


def _diagnose(spec: cs.CaseSpec, tmp_path: Path) -> tuple[dict, dict]:
    from hand_service.cli import main

    case = cs.build(spec)
    rec, model = cs.write(case, tmp_path)
    out = tmp_path / "diagnose.json"
    assert main(diagnose_argv(rec, model, out)) == 0
    truth = json.loads((tmp_path / f"{spec.id}.truth.json").read_text())
    return json.loads(out.read_text()), truth["library_equivalent"]


def test_the_ranges_reach_as_far_as_the_recordings_torques() -> None:
    paper = Param.effect("coulomb_friction", EffectScales(0.55, 60.0, 0.02, 2.0, 0.6))
    assert (paper.lower, paper.upper) == (0.0, fx.BY_NAME["coulomb_friction"].upper)  # the floor
    big = EffectScales(stiffness_nm_per_rad=5.0, command_max_kpa=70.0, torque_nm=3.0, speed_rad_s=6.0,
                       angle_rad=1.2)
    assert Param.effect("coulomb_friction", big).upper == 2.0 * 3.0
    gravity = Param.effect("gravity", big)
    assert math.isclose(gravity.upper, 10.0 * 3.0 / (1.0 - math.cos(1.2))) and gravity.lower == -gravity.upper
    assert math.isclose(Param.effect("quadratic_damping", big).upper, 10.0 * 3.0 / 6.0**2)
    small_angles = EffectScales(5.0, 70.0, 3.0, 6.0, 0.3)
    cubic = Param.effect("cubic_stiffness", small_angles)
    assert math.isclose(cubic.upper, 10.0 * 3.0 / 0.3**3)
    assert math.isclose(cubic.lower, -5.0 / (3.0 * 0.3**2))  # the spring stops resisting at 0.3 rad
    assert Param.effect("cubic_stiffness", big).lower == 5.0 * fx.BY_NAME["cubic_stiffness"].lower
    assert Param.effect("pressure_deadzone", big).upper == fx.BY_NAME["pressure_deadzone"].upper


def test_the_recordings_scales_are_read_off_the_simulated_angle() -> None:
    rate_hz = 100.0
    t = np.arange(0.0, 10.0, 1.0 / rate_hz)
    angle_deg = 40.0 * np.sin(2.0 * np.pi * 0.5 * t)
    scales = EffectScales.of(2.0, 0.01, np.full(t.size, 50.0), angle_deg, rate_hz)
    assert math.isclose(scales.angle_rad, math.radians(40.0), rel_tol=1e-3)
    assert math.isclose(scales.torque_nm, 2.0 * math.radians(40.0), rel_tol=1e-3)  # k·θ > N·p = 0.5
    top_speed = math.radians(40.0) * 2.0 * np.pi * 0.5
    assert 0.95 * top_speed < scales.speed_rad_s <= top_speed


def test_a_stiff_fingers_gravity_beyond_the_librarys_range_is_named(tmp_path: Path) -> None:
    """A stiff finger (k 4.9 N·m/rad) let go at 0 kPa under a posture-dependent gravity of
    2.8 N·m (the generator's form, with a mounting angle): the library's range, scaled by k
    alone, stopped at 2.1 N·m, the estimate stuck there and nothing was named."""
    spec = cs.CaseSpec("gravity", "free_release", 1, "evident", "stiff", 200.0)
    result, truth = _diagnose(spec, tmp_path)
    assert [e["name"] for e in result["effects"]] == ["gravity"], result["verdict"]
    found = result["effects"][0]["params"]["torque_nm"]
    assert abs(found / truth["torque_nm"] - 1.0) < 0.2
    assert abs(found) > 2.2  # beyond the old bound


@pytest.mark.thorough
def test_air_drag_in_a_fast_vent_beyond_the_librarys_range_is_named(tmp_path: Path) -> None:
    """A pressurised stiff finger vented: air drag (c2 0.071) beyond the library's range
    scaled by the refitted k (0.054): pinned there, it was left `unexplained`."""
    spec = cs.CaseSpec("quadratic_damping", "vent_release", 1, "evident", "stiff", 100.0)
    result, truth = _diagnose(spec, tmp_path)
    assert [e["name"] for e in result["effects"]] == ["quadratic_damping"], result["verdict"]
    found = result["effects"][0]["params"]["c2_nms2_per_rad2"]
    assert abs(found / truth["c2_nms2_per_rad2"] - 1.0) < 0.2

