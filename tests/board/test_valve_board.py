"""The HIL suite of tests/hil/test_valve_board.py, run against the reference firmware's host
build (board/) over serial-v1 on a pty and can-v1 behind SLCAN on a pty: the same tests the
Python mock passes, unchanged (the `rig` fixture of tests/board/conftest.py starts the C
firmware instead of the mock)."""

from __future__ import annotations

from tests.hil import test_valve_board as hil


class TestBoardFirmware(hil.TestValveBoard):
    # feeds the host's decoders directly and never starts a firmware: tests/hil runs it
    test_garbage_never_crashes_the_decoder = None
