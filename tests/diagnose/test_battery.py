"""The full concealed-effect battery (slow: `make bench` or `pytest -m slow`).

Every library effect x {steps, sweep} x 3 seeds, plus 12 clean recordings: fingers, noise
(0.3-1.0 deg), concealment (0.4-1.5 x noise) and ±10 % parameter errors drawn per seed.
The figures of docs/results.md §10 come from
`python -m hand_service.diagnose.concealed.battery`, which runs the same plan.
"""

from __future__ import annotations

import sys

import pytest

from hand_service.commands.progress import Progress
from hand_service.diagnose.concealed.battery import markdown, plan, run_case, summarise


@pytest.mark.slow
def test_battery_meets_the_targets(capsys: pytest.CaptureFixture[str]) -> None:
    cases = plan(seeds=3, excitations=("steps", "sweep"), clean_seeds=6)
    with capsys.disabled():  # a bar on a terminal, a line every few seconds in a log
        progress = Progress("battery", total=len(cases), stream=sys.stderr)
    for case in cases:
        run_case(case)
        with capsys.disabled():
            progress.advance(message=f"{case.effect} {case.excitation} seed {case.seed} -> "
                                     f"{case.verdict} {case.named}")
    summary = summarise(cases)
    with capsys.disabled():
        progress.close()
        print(markdown(summary, cases), file=sys.stderr)
    assert summary["top1_rate"] >= 0.9
    assert summary["false_positive_rate"] == 0.0
    assert summary["wrong_name_rate"] <= 0.05
    assert summary["median_parameter_error"] <= 0.25
    for name, figures in summary["per_effect"].items():
        assert figures["top1_rate"] >= 2 / 3, name
