"""The command line: help for every command, one-line errors with status 2."""

from __future__ import annotations

import subprocess
import sys

import pytest

from hand_service.cli import COMMANDS, main


def run_cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "hand_service.cli", *args], capture_output=True,
                          text=True, timeout=120)


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_every_command_explains_itself(command: str, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as info:
        main([command, "--help"])
    assert info.value.code == 0
    assert len(capsys.readouterr().out) > 200


def test_bad_input_is_one_line_and_status_2() -> None:
    result = run_cli("bench", "--profile", "/nonexistent/profile.yaml")
    assert result.returncode == 2
    assert result.stderr.strip().count("\n") == 0
    assert "Traceback" not in result.stderr
    assert "cannot read" in result.stderr


def test_run_demo_tracks(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", "--periods", "3"]) == 0
    out = capsys.readouterr().out
    mean = next(line for line in out.splitlines() if line.startswith("mean"))
    assert float(mean.split()[1]) < 3.0
