"""`bench` reports its progress through the project's progress wrapper: with stderr a file
(a log, CI) plain lines and never a `\\r` (--quiet, which silences them, is the wrapper's,
tested in tests/commands/test_progress.py)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path


def bench(tmp_path: Path, *extra: str) -> tuple[str, str]:
    """`hand-service bench` for a second of ticking, stdout and stderr to files."""
    out_path, err_path = tmp_path / "bench.out", tmp_path / "bench.err"
    with open(out_path, "w") as out, open(err_path, "w") as err:
        done = subprocess.run([sys.executable, "-m", "hand_service.cli", "bench", "--quick", "--seconds", "1",
                               "--no-realtime", "--recorder", "off", *extra],
                              stdout=out, stderr=err, timeout=120)
    stderr = err_path.read_bytes().decode()
    assert done.returncode == 0, stderr
    return out_path.read_bytes().decode(), stderr


def test_bench_to_a_file_writes_progress_lines_without_carriage_returns(tmp_path: Path) -> None:
    stdout, stderr = bench(tmp_path)
    assert "\r" not in stderr and "\r" not in stdout
    lines = [line for line in stderr.splitlines() if line.startswith("bench: [")]
    assert len(lines) == 1, stderr  # the first line at once, the next 2 s later: the run is over
    assert lines[0].split("]")[1].split()[:4] == ["100/100", "1", "of", "1"], lines  # one block, counted
    assert "supervisor tick at 100 Hz" in stdout and "jitter supervisor" in stdout

