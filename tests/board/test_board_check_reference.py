"""board-check against the reference firmware's host build (board/): the real C binary on a
pty, over serial-v1 and over can-v1 behind an SLCAN adapter, must pass every check,
including the reboot announcement through its debug port (test images have one). Nothing
is N/A: the host build regulates real (simulated) chambers, so zero-vent is measured."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from hand_service import cli
from hand_service.boardcheck.runner import CHECKS
from tests.board.firmware import BoardRig

# generous on a loaded 2-core machine (as tests/boardcheck does for the mock): the checks'
# own bounds are what a board must meet; --latency-ms is what this computer may add to them
OPTIONS = ["--seconds", "1", "--latency-ms", "400"]


@pytest.mark.parametrize("wire", ["serial", "slcan"])
def test_the_reference_firmware_passes_every_check(wire: str, tmp_path: Path, board_binary: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    with BoardRig(wire, tmp_path) as rig:
        rig.binary = board_binary
        rig.start_mock()
        target = [rig.channel] if wire == "serial" else ["--can", f"slcan:{rig.channel}"]
        out = tmp_path / "result.json"
        status = cli.main(["board-check", *target, *OPTIONS, "--quiet", "--json", str(out)])
        firmware_log = "\n".join(rig.lines)
    captured = capsys.readouterr()
    lines = captured.out.strip().splitlines()
    assert status == 0, f"{captured.out}\n--- firmware:\n{firmware_log[-3000:]}"
    assert [line.split()[:2] for line in lines[:-1]] == [["PASS", name] for name in CHECKS], captured.out
    assert lines[-1].startswith("PASS: ")
    result = json.loads(out.read_text())
    assert result["passed"] is True and result["stopped"] is None
    checks = {c["name"]: c for c in result["checks"]}
    assert [c["verdict"] for c in checks.values()] == ["PASS"] * len(CHECKS)
    assert checks["watchdog"]["values"]["vent_ms"] >= 100 - 10  # not before the profile's 100 ms
    assert checks["reboot-announce"]["values"]["uptime_after_ms"] < checks["reboot-announce"]["values"][
        "uptime_before_ms"]
    print(f"\n{wire}:", *lines, sep="\n  ")
