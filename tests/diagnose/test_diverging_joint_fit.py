"""A joint fit that drives the finger unstable is a very bad fit, not a crash
(search/forward_selection.evidence): the independent truth's pressure-dependent damping on
an over-damped finger's PRBS, where one effect's fit from its most promising start
diverged and diagnose exited with a traceback."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from tests.diagnose.truth import cases as cs
from tests.diagnose.truth.battery import diagnose_argv


def test_a_diverging_joint_fit_does_not_stop_diagnose(tmp_path: Path,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    from hand_service.cli import main

    case = cs.build(cs.CaseSpec("pressure_damping", "prbs", 0, "evident", "overdamped", 100.0, 1.0))
    rec, model = cs.write(case, tmp_path)
    out = tmp_path / "diagnose.json"
    assert main(diagnose_argv(rec, model, out)) == 0
    capsys.readouterr()
    result = json.loads(out.read_text())
    assert result["verdict"] in ("missing_physics", "unexplained", "insufficient_excitation",
                                 "parameters_only", "consistent")
    for effect in result["effects"]:
        assert math.isfinite(effect["delta_bic"])
