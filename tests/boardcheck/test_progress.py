"""board-check's progress goes through the project's one wrapper (hand_service/commands/
progress.py): with stderr to a file, plain lines and never a carriage return; with
--quiet, nothing on stderr; the results on stdout either way."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from hand_service.firmware.rig import Rig
from tests.boardcheck.conftest import TEST_OPTIONS

ONLY = ["--only", "report-rate,watchdog"]


def board_check(port: str, tmp_path: Path, *extra: str) -> tuple[int, str, str]:
    """Run `hand-service board-check` as its own process, stderr to a file."""
    err_path = tmp_path / f"stderr{len(list(tmp_path.glob('stderr*')))}.txt"
    with open(err_path, "w") as err:
        done = subprocess.run([sys.executable, "-m", "hand_service.cli", "board-check", port, *TEST_OPTIONS,
                               *ONLY, *extra], stdout=subprocess.PIPE, stderr=err, text=True, timeout=120)
    return done.returncode, done.stdout, err_path.read_text()


@pytest.fixture
def mock_port(tmp_path: Path):
    with Rig("serial", tmp_path) as rig:
        rig.start_mock()
        yield rig.channel


@pytest.mark.boardcheck  # 7 s: with make test-boardcheck
def test_progress_to_a_file_is_plain_lines_and_quiet_silences_it(mock_port: str, tmp_path: Path) -> None:
    status, out, err = board_check(mock_port, tmp_path)
    assert status == 0, out + err
    assert "\r" not in err and "\x1b" not in err, repr(err)  # no bar redrawn in place, no escapes
    progress = err.strip().splitlines()
    assert progress and all(line.startswith("board-check: [") for line in progress), err
    assert "handshake on" in progress[0]
    results = out.strip().splitlines()
    assert [line.split()[:2] for line in results[:-1]] == [["PASS", "handshake"], ["PASS", "report-rate"],
                                                           ["PASS", "watchdog"]], out
    assert results[-1].startswith("PASS: ")

    status, quiet_out, quiet_err = board_check(mock_port, tmp_path, "--quiet")
    assert status == 0, quiet_out + quiet_err
    assert quiet_err == ""
    assert [line.split()[:2] for line in quiet_out.splitlines()] == [line.split()[:2] for line in results]
