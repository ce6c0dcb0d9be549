"""The shutdown's vent reaches the reference firmware's host build too:
tests/hil/test_shutdown_vent.py, unchanged, over serial-v1 and SLCAN (marker `board`)."""

from __future__ import annotations

from tests.hil import test_shutdown_vent as hil

test_a_vent_queued_as_close_begins_reaches_the_board = hil.test_a_vent_queued_as_close_begins_still_goes_out
