"""command-echo judges the link's latency as the daemon does (transports/round_trip.py: the
smallest echo time over a sliding window): a board whose every sample comes 60 ms late
fails it; one echo that this busy host read late does not (the correct board over SLCAN
failed 1 of 5 runs on a loaded 2-core machine with one echo of 40.1 ms, limit 40)."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import pytest

from hand_service import cli
from tests.boardcheck.conftest import board
from tests.boardcheck.test_late_status import LateStatus

LATE_S = 0.06  # every frame the board sends: past the echo limit of two periods (20 ms) + 0


class LateLink(LateStatus):
    """Every frame the board sends goes out LATE_S late, in order."""

    def read(self, timeout_s: float) -> list[Any]:
        self._release()
        got = self.port.read(min(timeout_s, 0.002))  # often enough to release on time
        self._release()
        return got

    def write(self, units: list[Any]) -> None:
        now = time.monotonic()
        self._held += [(now + LATE_S, u) for u in units]
        self._release()


# the correct board's echo over every link is test_mock_passes's: here in make test-boardcheck only
@pytest.mark.parametrize("late", [True, pytest.param(False, marks=pytest.mark.boardcheck)])
def test_a_board_late_with_every_echo_fails_command_echo(late: bool, tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    with board("virtual", tmp_path, link_between=LateLink if late else None) as target:
        cli.main(["board-check", *target, "--seconds", "1", "--latency-ms", "0",
                  "--only", "command-echo", "--reboot", "skip"])
    out = capsys.readouterr().out
    line = next(line for line in out.splitlines() if line.split()[1:2] == ["command-echo"])
    if late:
        assert line.startswith("FAIL") and "every command for 250 ms took" in line, out
    else:
        assert line.startswith("PASS"), out
