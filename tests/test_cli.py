"""The command line: help for every command, one-line errors with status 2."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from hand_service.cli import COMMANDS, main
from hand_service.recording import read_recording


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


def test_run_demo_tracks(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    """`make run`: the demo through the real daemon, then its figures."""
    record = tmp_path / "demo.csv"
    assert main(["run", "--demo", "--no-realtime", "--no-socket", "--record", str(record)]) == 0
    out = capsys.readouterr().out
    mean = next(line for line in out.splitlines() if line.startswith("mean"))
    assert float(mean.split()[1]) < 3.0  # sweep RMSE (deg)
    pinch = out.split("pinch, force held at")[1].splitlines()[2:4]
    for line in pinch:
        _name, _est, true, mean_true = line.split()
        assert float(true) < 0.3 and abs(float(mean_true) - 1.5) < 0.3  # N
    assert "deadline misses" in out and "faults: none" in out
    assert "back in Python" in out  # the simulated hand ticks in C: the return is shown apart
    for finger in ("thumb", "index", "middle", "ring", "little"):
        assert read_recording(record, finger=finger).duration_s > 13.0


def test_bench_reports_tick_and_floor_keys(tmp_path: Path) -> None:
    out = tmp_path / "bench.json"
    result = run_cli("bench", "--quick", "--seconds", "1", "--no-realtime", "--record-sync-s", "0.5",
                     "--json", str(out))
    assert result.returncode == 0, result.stderr
    figures = json.loads(out.read_text())
    for key in ("c_step_ns_p50", "c_step_ns_p99", "python_step_ns_p50", "fingers", "tick_ns_p50",
                "tick_ns_p99", "jitter_us_p50", "jitter_us_p99", "jitter_us_max", "rate_hz",
                "jitter_floor_us_p50", "jitter_floor_us_p99", "jitter_floor_us_max",
                "deadline_misses", "deadline_misses_floor", "deadline_misses_woke_late", "ticks"):
        assert key in figures, key
    assert figures["ticks"] == 100 and figures["ticks_floor"] == 100 and figures["rate_hz"] == 100
    assert figures["record_sync_s"] == 0.5
    assert 0 < figures["tick_ns_p50"] <= figures["tick_ns_p99"]
    assert 0 <= figures["jitter_floor_us_p50"] <= figures["jitter_floor_us_p99"]
    assert 0 < figures["plant_ns_p50"] <= figures["plant_ns_p99"]  # the simulated hand, in the slack


def test_ctl_without_daemon_is_one_line(tmp_path: Path) -> None:
    result = run_cli("ctl", "--socket", str(tmp_path / "none.sock"), "status")
    assert result.returncode == 2
    assert result.stderr.strip().count("\n") == 0 and "cannot connect" in result.stderr
