"""board-check's SLCAN bus reads what the port holds at once and passes over the adapter's
replies, and makes the same frames of it as python-can's own slcanBus."""

from __future__ import annotations

import can
from can.interfaces.slcan import slcanBus

from hand_service.boardcheck.slcan import BulkSlcanBus, take_line

# replies to the host's own lines (z, Z, a bare OK, an ERROR) between two frames and an empty one
STREAM = b"z\rt1232AABB\rZ\r\a\rt4560\rt7FF80102030405060708\r"


def _frames(bus: can.BusABC) -> list[tuple[int, bytes]]:
    bus.serialPortOrig.write(STREAM)  # type: ignore[attr-defined]
    out = []
    while (frame := bus.recv(0.05)) is not None:
        out.append((frame.arbitration_id, bytes(frame.data)))
    return out


def test_the_bulk_bus_reads_the_frames_python_can_reads() -> None:
    expected = [(0x123, b"\xaa\xbb"), (0x456, b""), (0x7FF, bytes(range(1, 9)))]
    for kind in (slcanBus, BulkSlcanBus):
        bus = kind(channel="loop://", sleep_after_open=0)
        try:
            bus.flush()  # the loop echoes the bus's own opening lines
            assert _frames(bus) == expected, kind
        finally:
            bus.shutdown()


def test_no_reply_stops_a_receive_with_no_timeout() -> None:
    bus = BulkSlcanBus(channel="loop://", sleep_after_open=0)
    try:
        bus.flush()
        bus.serialPortOrig.write(STREAM)
        bus.recv(0.05)  # the wait for the first: the loop delivers once written
        assert [bus.recv(0.0) is not None for _ in range(3)] == [True, True, False]
    finally:
        bus.shutdown()


def test_a_line_is_taken_whole_with_its_end() -> None:
    buffer = bytearray(b"t1231FF\rt45")
    assert take_line(buffer) == "t1231FF\r"
    assert take_line(buffer) is None and buffer == bytearray(b"t45")
