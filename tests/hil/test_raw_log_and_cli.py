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


@pytest.mark.parametrize(("suffix", "channel_number"), [(".asc", ""), (".blf", ""), (".blf", "162381")])
def test_raw_traffic_log_replays_through_the_dbc(tmp_path: Path, suffix: str, channel_number: str) -> None:
    """A channel name may end in a number too big for BLF's 16-bit channel field (the rigs'
    random names do, now and then): the log then uses its own channel number."""
    log_path = tmp_path / f"session{suffix}"
    with Rig("virtual", tmp_path) as rig:
        rig.channel += f"-{channel_number}" if channel_number else ""
        rig.start_mock()
        transport = rig.transport(raw_log=str(log_path))
        transport.open()
        stop = threading.Event()
        holder = threading.Thread(target=hold, args=(transport, 25.0, stop), daemon=True)
        holder.start()
        # hold for 30 samples, each answered by a command of one frame per finger (about 0.3 s;
        # 5 s at most on a loaded machine)
        end = time.monotonic() + 5.0
        while transport.health().frames_out < 30 * len(rig.profile.fingers) and time.monotonic() < end:
            time.sleep(0.01)
        stop.set()
        holder.join(timeout=5)
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


def test_a_failing_raw_log_never_stops_the_link(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    """A raw log that cannot be written (a full disk) stops itself, with one error line; the
    reader thread, which records every frame it receives, goes on."""
    real_logger = can.Logger

    def full_disk(_frame: can.Message) -> None:
        raise OSError("disk full")

    def failing_logger(path: str) -> can.Listener:
        logger = real_logger(path)
        logger.on_message_received = full_disk  # type: ignore[method-assign]
        return logger

    with Rig("virtual", tmp_path) as rig:
        rig.start_mock()
        transport = rig.transport(raw_log=str(tmp_path / "session.asc"))
        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(can, "Logger", failing_logger)
            transport.open()  # the handshake's answer comes after the first frame failed to log
        sample = None
        end = time.monotonic() + 5.0
        while sample is None and time.monotonic() < end:
            sample = transport.latest()
            time.sleep(0.01)
        assert sample is not None
    errors = [r.getMessage() for r in caplog.records if r.levelname == "ERROR"]
    assert len(errors) == 1 and "disk full" in errors[0] and "raw logging stopped" in errors[0], errors
