"""python-can's SLCAN bus, read in bulk.

python-can's slcanBus reads its port one byte per call (a select and a read each) and
polls an empty port every millisecond. At can-v1's 100 Hz (a few frames a sample, about
12 kB/s of ASCII) that is over ten thousand system calls a second: on a busy machine
board-check fell behind the board, and a backlog that built up while it computed took
over 100 ms to read, every frame in it timed late and blamed on the board. This bus
takes everything the port holds in one read, and sleeps in select() until a byte comes.
The frames it returns are python-can's: only the reading of lines differs, and the
adapter's replies to the host's own lines (which carry no frame) are passed over, so that
a receive with no timeout reads on past them to the frames behind.
"""

from __future__ import annotations

import select

import serial
from can.exceptions import error_check
from can.interfaces.slcan import slcanBus

LINE_ENDS = (b"\r", b"\a")  # an SLCAN line ends in OK (CR) or ERROR (BEL)
# the adapter's replies to what this host sent: no frame in them
REPLIES = frozenset({"\r", "\a", "z\r", "Z\r"})


def take_line(buffer: bytearray) -> str | None:
    """The first whole line in `buffer` with its terminator, removed from it; None if none."""
    ends = [i for i in (buffer.find(end) for end in LINE_ENDS) if i >= 0]
    if not ends:
        return None
    stop = min(ends) + 1
    line = buffer[:stop].decode()
    del buffer[:stop]
    return line


class BulkSlcanBus(slcanBus):
    def _read(self, timeout: float | None) -> str | None:
        deadline = serial.Timeout(timeout)
        port = self.serialPortOrig
        with error_check("Could not read from serial device"):
            while True:
                line = take_line(self._buffer)
                while line in REPLIES:  # skipped: one look at the port reads every frame in it
                    line = take_line(self._buffer)
                if line is not None:
                    return line
                waiting = port.in_waiting
                if waiting:
                    self._buffer.extend(port.read(waiting))
                    continue
                if deadline.expired():
                    return None
                self._wait(port, deadline.time_left())

    def _wait(self, port: serial.SerialBase, timeout_s: float | None) -> None:
        """Until the port has a byte or timeout_s passed (None: no limit)."""
        try:
            fd = port.fileno()
        except (AttributeError, OSError, ValueError):  # io.UnsupportedOperation is both
            # a port with no descriptor (a URL): wait in a read of the port's own timeout
            self._buffer.extend(port.read(1))
            return
        select.select([fd], [], [], timeout_s)
