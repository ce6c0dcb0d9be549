"""The share of the mismatch an effect explains counts the refit's distance from the
nominal where that distance was evidence (verdict.prior_share): proven on a recording of the
independent truth generator (tests/diagnose/truth/) that the misfit's share alone left
`unexplained`."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.diagnose.truth import cases as cs
from tests.diagnose.truth.battery import diagnose_argv


@pytest.mark.thorough
def test_a_slow_valve_under_a_pi_loop_is_named_as_the_dominant_physics(tmp_path: Path) -> None:
    """An over-damped finger under a PI loop with a 54 ms valve lag: the refit mimics the
    lag with k, B and N some 300 times below the nominal, so the lag hardly lowers the
    misfit (0 % by the misfit's share) and all its ΔBIC is the prior's. It removes nearly
    all of the refit's distance from the nominal: named, as the dominant physics (the
    residual still follows the input)."""
    from hand_service.cli import main

    spec = cs.CaseSpec("valve_lag", "pi_steps", 2, "concealed", "overdamped", 500.0, 0.054)
    case = cs.build(spec)
    rec, model = cs.write(case, tmp_path)
    out = tmp_path / "diagnose.json"
    assert main(diagnose_argv(rec, model, out)) == 0
    result = json.loads(out.read_text())
    truth = json.loads((tmp_path / f"{spec.id}.truth.json").read_text())["library_equivalent"]
    assert [e["name"] for e in result["effects"]] == ["valve_lag"], result["verdict"]
    assert result["explained_share"] > 0.9
    assert abs(result["effects"][0]["params"]["tau_s"] / truth["tau_s"] - 1.0) < 0.2
