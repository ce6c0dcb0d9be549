"""A reader of the output that goes away (`hand-service ... | head -1`) ends the command
quietly, with a shell's status for SIGPIPE, never a traceback."""

from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path


def test_a_closed_pipe_ends_the_command_quietly(tmp_path: Path) -> None:
    command = [sys.executable, "-m", "hand_service.cli", "trials", "release", "--count", "2", "--finger",
               "index", "--out", str(tmp_path)]
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert process.stdout is not None and process.stderr is not None
    process.stdout.close()  # before it writes a line: every write it makes finds the pipe closed
    stderr = process.stderr.read()
    process.stderr.close()
    assert process.wait(120) == 128 + signal.SIGPIPE, stderr
    assert "Traceback" not in stderr and "BrokenPipe" not in stderr, stderr  # (its progress lines stay)
