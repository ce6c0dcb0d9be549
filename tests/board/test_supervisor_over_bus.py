"""The real `hand-service run` daemon holds a finger at a target through the reference
firmware's host build, over serial-v1 and over SLCAN: tests/hil/test_supervisor_over_bus.py,
unchanged, with the C firmware behind the pty (tests/board/conftest.py's rig)."""

from __future__ import annotations

from tests.hil import test_supervisor_over_bus as hil

test_supervisor_holds_a_target_through_the_board = hil.test_supervisor_holds_a_target_through_the_bus
