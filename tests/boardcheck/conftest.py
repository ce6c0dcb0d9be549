"""Boards for board-check to test: the C firmware, or an image of it that breaks one rule on
purpose (board/core/inject.h, enum inject_broken), on a link of its own (a pty in the
test's tmp dir, or a fresh virtual CAN channel), in a thread of this process; stopped, and
its port closed, when the test ends."""

from __future__ import annotations

import contextlib
import uuid
from collections.abc import Callable, Iterator
from pathlib import Path

import can

from hand_service.config.profile import load_profile
from hand_service.firmware.board import BoardFirmware, BoardThread
from hand_service.firmware.ports import CanBusPort, FirmwarePort, PtyPort, SlcanAdapterPort

PROFILES = {"serial": "serial-v1.yaml", "slcan": "can-v1-slcan.yaml", "virtual": "can-v1-virtual.yaml"}
# generous for a loaded 2-core machine: a board that breaks a rule fails whatever this is
TEST_OPTIONS = ["--seconds", "1", "--latency-ms", "400"]


@contextlib.contextmanager
def board(link: str, tmp_path: Path, broken: str | None = None,
          link_between: Callable[[FirmwarePort], FirmwarePort] | None = None) -> Iterator[list[str]]:
    """Start the firmware (breaking the rule `broken`) on `link`, seen through `link_between`
    (a port that holds or alters what crosses); yields board-check's arguments that reach it."""
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
    if link_between is not None:
        port = link_between(port)
    mock = BoardThread(BoardFirmware(profile, port, broken=broken)).start()
    try:
        yield args
    finally:
        mock.stop()
