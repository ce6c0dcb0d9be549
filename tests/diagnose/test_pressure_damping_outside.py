"""A damping that grows with the chamber pressure (the independent truth's, B·r·p/p_fs) is
in none of the library's forms: on the stiff finger's steps, where it leaves 3.8 times
the noise above the plain refit, diagnose says `unexplained` and names nothing."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.diagnose.truth import cases as cs
from tests.diagnose.truth.battery import diagnose_argv


@pytest.mark.thorough  # about 25 s
def test_a_pressure_dependent_damping_is_not_named(tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    from hand_service.cli import main

    case = cs.build(cs.CaseSpec("pressure_damping", "steps", 0, "evident", "stiff", 500.0, 1.151884130324884))
    assert case.visibility > 3.0
    rec, model = cs.write(case, tmp_path)
    out = tmp_path / "diagnose.json"
    assert main(diagnose_argv(rec, model, out)) == 0
    capsys.readouterr()
    result = json.loads(out.read_text())
    assert result["effects"] == []
    assert result["verdict"] == "unexplained"
