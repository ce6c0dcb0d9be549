"""run -> identify and diagnose: the daemon's recording goes straight into the model tools.

The real `hand-service run` process drives the simulated hand through its control socket:
the middle finger steps between angles (pressure that varies, for diagnose), then holds
and is vented (a release: a free decay, for identify; the middle finger rings longest,
ζ = 0.06). The recording is then read by both tools with `--finger middle` and no
conversion."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from hand_service.cli import main
from hand_service.config.profile import DEFAULT_PROFILE, load_profile
from tests.service.process import DaemonProcess, wait_for

TRAJECTORY = """\
t,angle_ref_deg_middle
0.0,0
1.0,0
1.2,30
3.0,30
3.2,60
5.0,60
5.2,20
7.0,20
7.2,45
8.5,45
8.51,
12.0,
"""


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    tmp = tmp_path_factory.mktemp("run_to_tools")
    trajectory = tmp / "steps.csv"
    trajectory.write_text(TRAJECTORY)
    daemon = DaemonProcess(tmp, "--duration", "60")
    try:
        with daemon.client() as client:
            daemon.disarmed(client)
            client.load_trajectory(trajectory)
            client.arm()
            client.start()
            wait_for(lambda: client.status()["state"] == "HOLD", 40.0, "the end of the trajectory")
        assert daemon.terminate() == 0, daemon.stderr.read_text()[-2000:]
    finally:
        daemon.close()
    return daemon.record


def test_identify_reads_the_release_in_a_daemon_recording(recording: Path, tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "identify.json"
    assert main(["identify", str(recording), "--model", str(DEFAULT_PROFILE), "--finger", "middle",
                 "--json", str(out)]) == 0
    result = json.loads(out.read_text())
    truth = load_profile().finger("middle").model
    assert result["stiffness_nm_per_rad"] == pytest.approx(truth.stiffness_nm_per_rad, rel=0.02)
    assert result["damping_nms_per_rad"] == pytest.approx(truth.damping_nms_per_rad, rel=0.08)
    capsys.readouterr()


def test_diagnose_finds_the_daemon_recording_consistent(recording: Path, tmp_path: Path,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    """The simulated hand is exactly the profile's model: nothing may be named missing."""
    out = tmp_path / "diagnose.json"
    assert main(["diagnose", str(recording), "--model", str(DEFAULT_PROFILE), "--finger", "middle",
                 "--json", str(out)]) == 0
    result = json.loads(out.read_text())
    assert result["verdict"] in ("consistent", "parameters_only"), result
    assert result["effects"] == []
    capsys.readouterr()
