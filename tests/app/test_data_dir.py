"""One data directory (docs/api.md): named by `run --data-dir` or the profile's
`recording.data_dir`, shown at start and in `ctl status`, named by every refusal."""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import pytest

from hand_service.api.paths import choose_data_dir
from hand_service.cli import main
from hand_service.config.profile import DEFAULT_PROFILE, load_profile
from tests.service.process import DaemonProcess

TRAJECTORY = "t,angle_ref_deg_index\n0,0\n0.5,30\n1.0,30\n"


def _profile_with_data_dir(folder: Path, data_dir: str) -> Path:
    folder.mkdir(exist_ok=True)
    text = DEFAULT_PROFILE.read_text().replace("hand:\n", f"recording:\n  data_dir: {data_dir}\n\nhand:\n", 1)
    path = folder / "mine.yaml"
    path.write_text(text)
    return path


def test_the_flag_then_the_profile_then_record_then_the_default(tmp_path: Path,
                                                                monkeypatch: pytest.MonkeyPatch) -> None:
    profile = load_profile(_profile_with_data_dir(tmp_path / "lab", "data"))
    assert profile.recording.data_dir == tmp_path / "lab" / "data"  # relative to the profile
    record = tmp_path / "runs" / "run.csv"
    assert choose_data_dir(tmp_path / "flag", profile.recording.data_dir, record)[0] == tmp_path / "flag"
    assert choose_data_dir(None, profile.recording.data_dir, record)[0] == tmp_path / "lab" / "data"
    assert choose_data_dir(None, None, record)[0] == tmp_path / "runs"
    monkeypatch.setenv("XDG_DATA_HOME", str(tmp_path / "xdg"))
    default = tmp_path / "xdg" / "hand-service" / "recordings"
    assert choose_data_dir(None, None, None) == (default, "the default")


@pytest.fixture
def daemon(tmp_path: Path) -> Iterator[DaemonProcess]:
    profile = _profile_with_data_dir(tmp_path / "lab", "data")
    running = DaemonProcess(tmp_path, "--profile", str(profile), "--duration", "120", "--status", "off")
    try:
        with running.client() as hand:
            running.disarmed(hand)
        yield running
    finally:
        running.close()


def test_shown_at_start_and_in_status_and_named_by_every_refusal(daemon: DaemonProcess, tmp_path: Path,
                                                                 capsys: pytest.CaptureFixture[str]) -> None:
    data = os.path.realpath(tmp_path / "lab" / "data")
    assert daemon.proc.stdout is not None
    first = daemon.proc.stdout.readline()
    assert first.startswith(f"data directory: {data} (the profile's recording.data_dir;"), first
    assert main(["ctl", "--socket", str(daemon.socket), "status"]) == 0
    assert f"data directory {data}" in capsys.readouterr().out

    outside = tmp_path / "wave.csv"
    outside.write_text(TRAJECTORY)
    for args in (["load", str(outside)], ["record-start", str(tmp_path / "new.csv")],
                 ["record-start", f"{data}/no/such/dir/new.csv"]):
        assert main(["ctl", "--socket", str(daemon.socket), *args]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and data in err, (args, err)
    inside = Path(data) / "wave.csv"
    inside.write_text(TRAJECTORY)
    assert main(["ctl", "--socket", str(daemon.socket), "load", str(inside)]) == 0
