"""The fault matrix of docs/safety.md against the reference firmware's host build: every
fault the firmware injects on its debug port, over serial-v1 and over SLCAN, must end in
FAULT with a vent within its bound, the first fault naming the check meant to catch it
(tests/hil/matrix.py, unchanged). Marker `board`: make test-board-host.

One allowance, over SLCAN only: a drop or corruption of 30 % of the frames loses about
83 % of the samples there (can-v1 sends one frame per finger, and a sample needs all
five), so two checks race at about 100 ms: stale_sensor, judged when the next whole sample
arrives, and sample_late, judged on the board's clock when none has. Which one trips first
depends on the random draws of that run (the Python mock's seed happens to favour the
first; the C firmware's runs have shown both). Either is a correct catch, so sample_late
is accepted there; the bound on the vent is not relaxed."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.board.firmware import BoardRig
from tests.hil.matrix import CASES, problems, run_session, table

RACE = ("slcan/drop: first fault sample_late", "slcan/corrupt: first fault sample_late")


@pytest.mark.board
@pytest.mark.parametrize("link", ["serial", "slcan"])
def test_fault_matrix_against_the_board(link: str, tmp_path: Path, board_binary: Path) -> None:
    cases = [c for c in CASES if c.on(link)]
    with BoardRig(link, tmp_path) as rig:
        rig.binary = board_binary
        outcomes = run_session(rig, cases, wrong_version=True)
    print(f"\n{table(outcomes)}")
    assert len(outcomes) == len(cases) + 1, [o.case for o in outcomes]
    assert [p for p in problems(outcomes) if not p.startswith(RACE)] == [], table(outcomes)
