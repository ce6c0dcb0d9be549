"""A board whose answer to the handshake comes out of order (its Status held 30 ms behind the
VersionInfo written with it): the answer then reads VersionInfo first. board-check says that
the Status came after its VersionInfo, not that there was none. Only the answer's Status is
held (not the one written after the VersionInfo at boot), and no heartbeat Status passes before
the answer: one let out between a request and its answer would rightly count as the answer's."""

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

HOLD_S = 0.03
STATUS_ID = load_file(str(PROFILE_DIR / "can-v1.dbc")).get_message_by_name("Status").frame_id
VERSION_ID = load_file(str(PROFILE_DIR / "can-v1.dbc")).get_message_by_name("FirmwareVersion").frame_id


class LateStatus(FirmwarePort):
    """The Status the board writes with a VersionInfo (the handshake's answer) goes out HOLD_S
    late, behind the VersionInfo."""

    def __init__(self, port: FirmwarePort) -> None:
        self.port = port
        self.carries_error_frames = port.carries_error_frames
        self._held: list[tuple[float, can.Message]] = []
        self.answered = False

    def read(self, timeout_s: float) -> list[Any]:
        self._release()
        return self.port.read(timeout_s)

    def write(self, units: list[Any]) -> None:
        now = time.monotonic()
        ids = [u.arbitration_id for u in units]
        # the answer is Status then VersionInfo; at boot the board writes them the other way
        answer = any(ids[i:i + 2] == [STATUS_ID, VERSION_ID] for i in range(len(ids) - 1))
        late = [u for u in units if answer and u.arbitration_id == STATUS_ID]
        self._held += [(now + HOLD_S, u) for u in late]
        self.answered = self.answered or answer
        # until the handshake's answer, no heartbeat Status passes: one let out between the
        # request and its answer would rightly count as the answer's
        self.port.write([u for u in units if u not in late
                         and (self.answered or u.arbitration_id != STATUS_ID)])
        self._release()

    def _release(self) -> None:
        now = time.monotonic()
        due = [u for t, u in self._held if t <= now]
        self._held = [(t, u) for t, u in self._held if t > now]
        if due:
            self.port.write(due)

    def close(self) -> None:
        self.port.close()


def test_a_late_status_is_named_as_out_of_order(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    with board("virtual", tmp_path, link_between=LateStatus) as target:
        code = cli.main(["board-check", *target, "--seconds", "1", "--latency-ms", "100",
                         "--only", "sequence", "--reboot", "skip"])
    out = capsys.readouterr().out
    assert code == 1, out
    line = next(line for line in out.splitlines() if line.split()[1:2] == ["handshake"])
    assert line.startswith("FAIL") and "Status came" in line and "after its VersionInfo" in line, out


class HeartbeatOnlyVent(LateStatus):
    """The board vents on its watchdog in time, but says so only 150 ms later (as if with a
    later heartbeat, not at once on the change)."""

    DB = load_file(str(PROFILE_DIR / "can-v1.dbc"))

    def write(self, units: list[Any]) -> None:
        now = time.monotonic()
        late = [u for u in units if u.arbitration_id == STATUS_ID
                and self.DB.decode_message(STATUS_ID, u.data, decode_choices=False)["state"] == 3]
        self._held += [(now + 0.15, u) for u in late]
        self.port.write([u for u in units if u not in late])
        self._release()


def test_a_vent_status_sent_late_is_not_a_late_vent(tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    with board("virtual", tmp_path, link_between=HeartbeatOnlyVent) as target:
        code = cli.main(["board-check", *target, "--seconds", "1", "--latency-ms", "20",
                         "--only", "watchdog", "--reboot", "skip"])
    out = capsys.readouterr().out
    assert code == 1, out
    line = next(line for line in out.splitlines() if line.split()[1:2] == ["watchdog"])
    assert line.startswith("FAIL") and "the chambers fell" in line and "Status at once" in line, out
