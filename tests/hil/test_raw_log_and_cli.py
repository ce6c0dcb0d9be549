"""Raw CAN traffic logs that lab tools replay, and the mock-firmware command's errors."""

from __future__ import annotations

import subprocess
import sys
import threading
import time
from pathlib import Path

import can
import pytest

from hand_service.firmware.hold import hold
from hand_service.firmware.rig import Rig
from hand_service.wire.messages import SensorReport, ValveCommand


@pytest.mark.parametrize("suffix", [".asc", ".blf"])
def test_raw_traffic_log_replays_through_the_dbc(tmp_path: Path, suffix: str) -> None:
    log_path = tmp_path / f"session{suffix}"
    with Rig("virtual", tmp_path) as rig:
        rig.start_mock()
        transport = rig.transport(raw_log=str(log_path))
        transport.open()
        hold(transport, 25.0, threading.Event(), seconds=0.5)
        transport.close()
        codec = rig.transport().codec
    decoded = [m for frame in can.LogReader(str(log_path)) for m in codec.decode(frame)]
    assert sum(isinstance(m, SensorReport) for m in decoded) > 20
    assert any(isinstance(m, ValveCommand) and m.pressure_cmd_kpa[0] == pytest.approx(25.0) for m in decoded)


def _cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "hand_service.cli", "mock-firmware", *args],
                          capture_output=True, text=True, timeout=60)


@pytest.mark.parametrize(("profile", "message"), [
    ("can-v1-virtual.yaml", "virtual bus lives inside one process"),
    ("sim.yaml", "has no firmware to mock"),
])
def test_mock_firmware_refuses_clearly(profile: str, message: str) -> None:
    result = _cli("--profile", profile)
    assert result.returncode == 2
    assert message in result.stderr and result.stderr.strip().count("\n") == 0


def test_mock_firmware_stops_on_its_own_and_removes_its_port(tmp_path: Path) -> None:
    port = tmp_path / "fw.pty"
    started = time.monotonic()
    result = _cli("--profile", "serial-v1.yaml", "--port", str(port), "--seconds", "0.3")
    assert result.returncode == 0, result.stderr
    assert f"ready: {port}" in result.stdout
    assert not port.exists() and time.monotonic() - started < 30
