"""--latency-ms is what the link may add to any time the board keeps, the handshake's
answer included: an emulated board behind QEMU's one-byte UART once left ten
VersionRequests unanswered for the profile's whole second, with its status streaming."""

from __future__ import annotations

from pathlib import Path

import pytest

from hand_service import cli
from hand_service.firmware.mock import MockFirmware
from hand_service.wire.messages import Message, VersionRequest
from tests.boardcheck.conftest import board

LATE_S = 1.2  # the first requests this long go unanswered: past the profile's 1 000 ms


class LateAnswerFirmware(MockFirmware):
    """Answers no VersionRequest until LATE_S after the first one came (a link that holds them)."""

    _first_request_s: float | None = None

    def _handle(self, message: Message, now: float) -> None:
        if isinstance(message, VersionRequest):
            if self._first_request_s is None:
                self._first_request_s = now
            if now - self._first_request_s < LATE_S:
                return
        super()._handle(message, now)


@pytest.mark.boardcheck
@pytest.mark.parametrize(("latency_ms", "status"), [("400", 0), ("0", 1)])
def test_the_handshake_waits_for_what_the_link_may_add(latency_ms: str, status: int, tmp_path: Path,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    with board("virtual", tmp_path, LateAnswerFirmware) as target:
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
