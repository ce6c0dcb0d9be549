"""A release is recognised from the first sample (problem.build_problem): a ringing finger
let go swings through rest within the 50 ms a median of the first samples spans."""

from __future__ import annotations

from pathlib import Path

from hand_service.config.profile import load_model
from hand_service.diagnose.model.problem import build_problem
from hand_service.recording import read_recording
from tests.diagnose.truth import cases as cs
from tests.diagnose.truth.battery import diagnose_in_process

# a ringing finger let go from 32°, 1 kHz: at −20° 50 ms later
SPEC = cs.CaseSpec("asymmetric_stiffness", "free_release", 1, "evident", "ringing", 1000.0, 0.53728412601)


def test_a_fast_release_is_taken_as_a_release_and_its_asymmetry_named(tmp_path: Path) -> None:
    case = cs.build(SPEC)
    assert case.observable
    rec_path, model_path = cs.write(case, tmp_path)
    rec = read_recording(rec_path, None)
    problem = build_problem(load_model(model_path, None), rec.t_s, rec.pressure_kpa, rec.angle_deg, 1000.0)
    assert problem.blocks[0][0] == 0  # the first swings count (a start at rest skipped 0.35 s)
    assert problem.angle0_deg == rec.angle_deg[0]
    result = diagnose_in_process(rec_path, model_path, tmp_path)
    assert [e["name"] for e in result["effects"]] == ["asymmetric_stiffness"], result["verdict"]
    found = result["effects"][0]["params"]["stiffness_ratio"]
    assert abs(found / case.library_equivalent["stiffness_ratio"] - 1.0) < 0.1
