"""A borderline candidate is tested on a second, disjoint held-out quarter of the blocks
(search.second_split_z, Problem.rotated): twice the held-out data for an effect whose one
quarter's z falls between 1 and 2."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from hand_service.config.model import FingerModel
from hand_service.diagnose.model.problem import build_problem
from tests.diagnose.truth import cases as cs
from tests.diagnose.truth.battery import diagnose_argv


def test_the_second_split_holds_out_another_quarter_of_the_same_samples() -> None:
    rate_hz, n = 100.0, 3000
    model = FingerModel(inertia_kgm2=1.6e-4, damping_nms_per_rad=0.003, stiffness_nm_per_rad=0.57,
                        pressure_gain_nm_per_kpa=0.0119)
    t = np.arange(n) / rate_hz
    problem = build_problem(model, t, np.full(n, 30.0), np.zeros(n), rate_hz)
    other = problem.rotated()
    assert not np.any(other.held_mask & problem.held_mask)  # disjoint held-out samples
    assert np.array_equal(other.fit_mask | other.held_mask, problem.fit_mask | problem.held_mask)
    assert not np.any(other.fit_mask & other.held_mask)
    block = problem.blocks[0][1] - problem.blocks[0][0]
    assert abs(int(other.held_mask.sum()) - int(problem.held_mask.sum())) <= block  # a quarter each


def test_a_concealed_stiffening_that_one_quarter_leaves_borderline_is_named(tmp_path: Path) -> None:
    """An over-damped finger stepped at 500 Hz with a concealed power-law stiffening
    (library equivalent k3 0.0114): ΔBIC 75, but the first held-out quarter gave z 1.56
    and it was left `insufficient_excitation`; the second quarter confirms it."""
    from hand_service.cli import main

    spec = cs.CaseSpec("cubic_stiffness", "steps", 0, "concealed", "overdamped", 500.0, 0.0304)
    rec, model = cs.write(cs.build(spec), tmp_path)
    out = tmp_path / "diagnose.json"
    assert main(diagnose_argv(rec, model, out)) == 0
    result = json.loads(out.read_text())
    truth = json.loads((tmp_path / f"{spec.id}.truth.json").read_text())["library_equivalent"]
    assert [e["name"] for e in result["effects"]] == ["cubic_stiffness"], result["verdict"]
    assert abs(result["effects"][0]["params"]["k3_nm_per_rad3"] / truth["k3_nm_per_rad3"] - 1.0) < 0.2
