"""board-check passes the mock firmware on every link it speaks: serial-v1 on a pty and
can-v1 through an SLCAN adapter on a pty (the mock in its own process, as a lab's board
is), and can-v1 on python-can's virtual bus (the mock in a thread: the bus lives in one
process). The SLCAN run is in `make test-boardcheck` (marker boardcheck), to keep make test short."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from hand_service import cli
from hand_service.boardcheck.runner import CHECKS
from hand_service.firmware.rig import Rig
from tests.boardcheck.conftest import TEST_OPTIONS


@pytest.mark.parametrize("link", ["serial", pytest.param("slcan", marks=pytest.mark.boardcheck),
                                  pytest.param("virtual", marks=pytest.mark.boardcheck)])
def test_every_check_passes_on_the_mock(link: str, tmp_path: Path,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    with Rig(link, tmp_path) as rig:
        rig.start_mock()
        target = [rig.channel] if link == "serial" else ["--can", f"{link}:{rig.channel}"]
        out = tmp_path / "result.json"
        status = cli.main(["board-check", *target, *TEST_OPTIONS, "--json", str(out)])
    captured = capsys.readouterr()
    lines = captured.out.strip().splitlines()
    assert status == 0, captured.out
    assert [line.split()[1] for line in lines[:-1]] == list(CHECKS)
    assert all(line.startswith("PASS") for line in lines), captured.out
    result = json.loads(out.read_text())
    assert result["passed"] is True
    assert [c["verdict"] for c in result["checks"]] == ["PASS"] * len(CHECKS)
    watchdog = next(c for c in result["checks"] if c["name"] == "watchdog")
    # not before the profile's 100 ms, less one sample: on the host's clock alone (vent_ms is less
    # what this host read late)
    assert watchdog["values"]["vent_ms"] + watchdog["values"]["own_stall_ms"] >= 100 - 10
    assert "board-check: [" in captured.err and "handshake on" in captured.err  # progress: stderr
