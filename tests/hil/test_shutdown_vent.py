"""The shutdown's vent is never lost: a command queued as close() begins, while the writer
thread is still busy writing the previous one, goes out before the writer ends."""

from __future__ import annotations

import numpy as np

from hand_service.firmware.rig import Rig
from hand_service.wire.messages import Message, ValveCommand


def test_a_vent_queued_as_close_begins_still_goes_out(rig: Rig) -> None:
    rig.start_mock()
    transport = rig.transport()
    transport.open()
    written: list[ValveCommand] = []
    write = transport._write

    def slow_write(message: Message) -> None:
        write(message)
        if isinstance(message, ValveCommand):
            written.append(message)
            if max(message.pressure_cmd_kpa) > 0:
                # close() begins while this write is in flight, just after the shutdown's vent
                transport.vent()
                transport._stop.set()

    transport._write = slow_write  # type: ignore[method-assign]
    try:
        transport.send(np.full(transport.n_fingers, 20.0))
        for thread in transport._threads:
            thread.join(timeout=10.0)
    finally:
        transport.close()
    assert [max(c.pressure_cmd_kpa) for c in written] == [20.0, 0.0]
