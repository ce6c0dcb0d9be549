"""--latency-ms is what the link may add to any time the board keeps, the handshake's
answer included: an emulated board behind QEMU's one-byte UART once left ten
VersionRequests unanswered for the profile's whole second, with its status streaming."""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import can
import pytest
from cantools.database import load_file

from hand_service import cli
from hand_service.config.profile import PROFILE_DIR
from hand_service.firmware.ports import FirmwarePort
from tests.boardcheck.conftest import board

LATE_S = 1.2  # the first requests this long go unanswered: past the profile's 1 000 ms
VERSION_REQUEST_ID = load_file(str(PROFILE_DIR / "can-v1.dbc")).get_message_by_name("VersionRequest").frame_id


class LateLink(FirmwarePort):
    """A CAN link that loses every VersionRequest until LATE_S after the first one came."""

    def __init__(self, port: FirmwarePort) -> None:
        self.port = port
        self.carries_error_frames = port.carries_error_frames
        self._first_request_s: float | None = None

    def read(self, timeout_s: float) -> list[Any]:
        return [frame for frame in self.port.read(timeout_s) if not self._held(frame)]

    def _held(self, frame: can.Message) -> bool:
        if frame.arbitration_id != VERSION_REQUEST_ID:
            return False
        now = time.monotonic()
        if self._first_request_s is None:
            self._first_request_s = now
        return now - self._first_request_s < LATE_S

    def write(self, units: list[Any]) -> None:
        self.port.write(units)

    def close(self) -> None:
        self.port.close()


@pytest.mark.boardcheck
@pytest.mark.parametrize(("latency_ms", "status"), [("400", 0), ("0", 1)])
def test_the_handshake_waits_for_what_the_link_may_add(latency_ms: str, status: int, tmp_path: Path,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    with board("virtual", tmp_path, link_between=LateLink) as target:
        code = cli.main(["board-check", *target, "--seconds", "1", "--latency-ms", latency_ms,
                         "--only", "sequence", "--reboot", "skip"])
    out = capsys.readouterr().out
    handshake = [line for line in out.splitlines() if line.split()[1:2] == ["handshake"]]
    assert len(handshake) == 1, out
    if status == 0:
        assert handshake[0].startswith("PASS"), out
    else:
        assert code == 1 and handshake[0].startswith("FAIL"), out
        assert "no VersionInfo within 1000 ms" in handshake[0], out
