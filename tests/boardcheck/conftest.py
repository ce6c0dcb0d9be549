"""Boards for board-check to test: the mock firmware, or one of its broken variants, on a
link of its own (a pty in the test's tmp dir, or a fresh virtual CAN channel), in a
thread of this process; stopped, and its port closed, when the test ends."""

from __future__ import annotations

import contextlib
import uuid
from collections.abc import Iterator
from pathlib import Path

import can

from hand_service.config.profile import load_profile
from hand_service.firmware.mock import MockFirmware, MockThread
from hand_service.firmware.ports import CanBusPort, FirmwarePort, PtyPort, SlcanAdapterPort

PROFILES = {"serial": "serial-v1.yaml", "slcan": "can-v1-slcan.yaml", "virtual": "can-v1-virtual.yaml"}
# generous for a loaded 2-core machine: a board that breaks a rule fails whatever this is
TEST_OPTIONS = ["--seconds", "1", "--latency-ms", "400"]


@contextlib.contextmanager
def board(link: str, tmp_path: Path, firmware: type[MockFirmware] = MockFirmware) -> Iterator[list[str]]:
    """Start `firmware` on `link`; yields board-check's arguments that reach it."""
    profile = load_profile(PROFILES[link])
    port: FirmwarePort
    if link == "virtual":
        channel = f"board-check-{uuid.uuid4().hex[:12]}"
        port = CanBusPort(can.Bus(interface="virtual", channel=channel))
        args = ["--can", f"virtual:{channel}"]
    else:
        path = tmp_path / f"{link}.pty"
        pty = PtyPort(path)
        port = pty if link == "serial" else SlcanAdapterPort(pty)
        args = [str(path)] if link == "serial" else ["--can", f"slcan:{path}"]
    mock = MockThread(firmware(profile, port)).start()
    try:
        yield args
    finally:
        mock.stop()
