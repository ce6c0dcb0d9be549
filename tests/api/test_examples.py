"""The lab's scripts against a real daemon: `ctl` prints every reply in one readable form
(and one line of JSON with --json), and docs/examples/python/control_hand.py arms, sets a
target, starts, records and stops over the TCP port with the token."""

from __future__ import annotations

import json
import re
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from hand_service.cli import main
from hand_service.recording import read_recording
from tests.service.process import DaemonProcess, wait_for

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "docs" / "examples" / "python" / "control_hand.py"


class TcpDaemon(DaemonProcess):
    """`run --tcp-port 0 --record-dir <tmp>/rec`, recording nothing until asked."""

    def __init__(self, tmp_path: Path) -> None:
        self.socket = tmp_path / "api.sock"
        self.record_dir = tmp_path / "rec"
        self.stderr = tmp_path / "stderr.txt"
        with open(self.stderr, "w") as err:
            self.proc = subprocess.Popen(
                [sys.executable, "-m", "hand_service.cli", "run", "--no-realtime", "--socket",
                 str(self.socket), "--record-dir", str(self.record_dir), "--tcp-port", "0",
                 "--duration", "120"],
                stdout=subprocess.PIPE, stderr=err, text=True)
        self.port = int(wait_for(self._port, 30.0, "the TCP port in the log"))

    def _port(self) -> str | None:
        assert self.proc.poll() is None, self.stderr.read_text()
        match = re.search(r"control API on 127\.0\.0\.1:(\d+)", self.stderr.read_text())
        return match.group(1) if match else None


@pytest.fixture
def daemon(tmp_path: Path) -> Iterator[TcpDaemon]:
    running = TcpDaemon(tmp_path)
    try:
        with running.client() as hand:
            running.disarmed(hand)
        yield running
        assert running.terminate(20.0) == 0, running.stderr.read_text()[-2000:]
    finally:
        running.close()


def ctl(daemon: TcpDaemon, capsys: pytest.CaptureFixture[str], *args: str) -> str:
    assert main(["ctl", "--socket", str(daemon.socket), *args]) == 0
    return capsys.readouterr().out


def test_ctl_replies_read_alike_and_json_is_one_line(daemon: TcpDaemon,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    assert ctl(daemon, capsys, "arm") == "state: ARMED\n"
    assert ctl(daemon, capsys, "target", "index", "--angle-deg", "30") == \
        "fingers: index\nangle_deg: 30\nmode: position\napplies: from start\n"
    status = ctl(daemon, capsys, "--json", "status")
    assert status.count("\n") == 1 and json.loads(status)["fingers"]["index"]["target_mode"] == "position"
    assert json.loads(ctl(daemon, capsys, "--json", "faults")) == {"counts": {}, "total": 0, "faults": []}
    faults = ctl(daemon, capsys, "faults")
    assert faults == "counts: -\ntotal: 0\nfaults: -\n"
    assert ctl(daemon, capsys, "status").startswith("ARMED  t = ")  # the table
    assert main(["ctl", "--socket", str(daemon.socket), "--tcp-port", str(daemon.port), "disarm"]) == 0
    assert capsys.readouterr().out == "state: DISARMED\n"  # over TCP, the token read beside the socket


def test_the_python_example_drives_the_hand_and_records(daemon: TcpDaemon) -> None:
    record = daemon.record_dir / "example.csv"
    done = subprocess.run([sys.executable, str(EXAMPLE), "--socket", str(daemon.socket), "--tcp-port",
                           str(daemon.port), "--record", str(record), "--finger", "index", "--angle-deg",
                           "45", "--seconds", "2"], capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert done.returncode == 0, done.stderr
    lines = done.stdout.splitlines()
    assert lines[:2] == ["arm: ARMED",
                         "target: {'fingers': ['index'], 'angle_deg': 45.0, 'mode': 'position', "
                         "'applies': 'from start'}"]
    assert lines[2] == "start: RUNNING" and lines[-1] == "disarm: DISARMED"
    recorded = re.fullmatch(r"recorded (\d+) rows to .*example\.csv", lines[-2])
    assert recorded is not None, lines
    rows = int(recorded.group(1))
    assert rows >= 150  # 2 s at 100 Hz, give or take the stop
    wait_for(lambda: record.exists() and len(record.read_text().splitlines()) > rows, 10.0, "the recording")
    recording = read_recording(record, finger="index")
    running = np.array([s == "RUNNING" for s in recording.text_columns["state"]])
    assert running.sum() >= 150 and set(recording.text_columns["mode"]) == {"position"}
    assert np.all(recording.columns["angle_ref_deg"][running] == 45.0)
    assert recording.angle_deg[running][-20:].mean() > 30.0  # the finger went there


def test_the_python_example_refuses_in_one_line_and_vents(daemon: TcpDaemon, tmp_path: Path) -> None:
    outside = tmp_path / "elsewhere.csv"  # not in the recording directory: the daemon refuses it
    done = subprocess.run([sys.executable, str(EXAMPLE), "--socket", str(daemon.socket), "--record",
                           str(outside), "--seconds", "0"], capture_output=True, text=True, timeout=120,
                          cwd=ROOT)
    assert done.returncode == 2 and done.stderr.count("\n") == 1, done.stderr
    assert "outside the data directory" in done.stderr and not outside.exists()
    assert done.stdout.splitlines()[-1] == "disarm: DISARMED"  # armed and started before: vented
    with daemon.client() as hand:
        assert hand.status()["state"] == "DISARMED"
