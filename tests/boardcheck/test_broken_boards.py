"""board-check fails, with a line that says what is wrong, against boards that each break
one rule (board/core/inject.h, enum inject_broken). The checks that cannot see the broken rule
are left out with --only, to keep each test short."""

from __future__ import annotations

from pathlib import Path

import pytest

from hand_service import cli
from tests.boardcheck.conftest import TEST_OPTIONS, board

CASES = [
    # variant, link, checks to run, the failing check, words its line must hold
    ("no-watchdog", "virtual", "watchdog", "watchdog", "no watchdog_vented Status within"),
    ("wrong-crc", "serial", None, "handshake", "came with a bad CRC"),
    ("stuck-sequence", "virtual", "sequence", "sequence", "must go up by one with every sample"),
    # the plant through the board, each failure naming its finger (INJECT_BROKEN_FINGER: index)
    ("valves-dead", "virtual", "plant", "plant", "every finger: the valve did not move the chamber"),
    # (the stuck chamber's reading is its rest's, a sensor's noise either side of 0 kPa)
    ("valve-stuck", "serial", "plant", "plant", "index: the valve did not move the chamber (index "),
    ("pressure-nan", "virtual", "plant", "plant", "every finger: chamber pressure NaN (not measured) where"),
    ("pressure-x2", "slcan", "plant", "plant", "the chamber reads at another scale than the setpoint"),
    ("flex-stuck", "virtual", "plant", "plant", "index: flex sensor did not move with the pressure step"),
    ("flex-x2", "serial", "plant", "plant", "index: flex sensor moved at another scale"),
    # the others with make test-boardcheck (make test keeps the three)
    pytest.param("wrong-crc", "virtual", None, "handshake", "came with a bad CRC",
                 marks=pytest.mark.boardcheck),
    pytest.param("echo-version", "virtual", "version-refusal", "version-refusal", "must not claim a protocol",
                 marks=pytest.mark.boardcheck),
    pytest.param("silent-reboot", "virtual", "reboot-announce", "reboot-announce", "no VersionInfo before",
                 marks=pytest.mark.boardcheck),
    pytest.param("quiet-idle", "virtual", "report-rate", "report-rate", "whether or not it is commanded",
                 marks=pytest.mark.boardcheck),
    pytest.param("counts-rubbish", "serial", "crc-and-garbage", "crc-and-garbage",
                 "rubbish with no frame in it", marks=pytest.mark.boardcheck),
    pytest.param("zero-vents", "slcan", "zero-vent", "zero-vent", "left the running state on a zero command",
                 marks=pytest.mark.boardcheck),
]


@pytest.mark.parametrize(("variant", "link", "only", "check", "words"), CASES,
                         ids=[f"{c[0]}-{c[1]}" if isinstance(c, tuple) else f"{c.values[0]}-{c.values[1]}"
                              for c in CASES])
def test_a_broken_board_fails_with_a_clear_line(variant: str, link: str, only: str | None, check: str,
                                                words: str, tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    with board(link, tmp_path, variant) as target:
        status = cli.main(["board-check", *target, *TEST_OPTIONS, *(["--only", only] if only else [])])
    out = capsys.readouterr().out
    assert status == 1, out
    failing = [line for line in out.splitlines() if line.startswith("FAIL") and line.split()[1] == check]
    assert len(failing) == 1, out
    assert words in failing[0], out
    assert out.strip().splitlines()[-1].startswith("FAIL: ")
