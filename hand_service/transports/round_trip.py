"""The link's latency on the host's clock alone: command -> sensor round trip.

A SensorReport carries `command_sequence`, the newest valve command the board held when
it took the sample. The host stamps each command as it is counted and each sample as it
arrives, both on its own monotonic clock, so the time from a command to the first sample
that echoes it is the link's delay out, the wait for the board's next sample (up to one
sample period) and the link's delay back. No board clock enters it: a board whose clock
runs slow or fast leaves it unchanged (board_clock.ClockDrift measures that), and a
delay, in either direction, always shows in it.

The estimate is the smallest round trip over the last WINDOW_S: one command the host
itself was late to read the echo of (its reader thread stalled) does not raise it; a
link that is late for all of them does, within that window.
"""

from __future__ import annotations

from collections import deque

WINDOW_S = 0.25
RING = 256  # commands remembered by sequence; the echo is never that far behind


class RoundTrip:
    """The command -> echo round trip (s), its smallest over a sliding window."""

    def __init__(self, window_s: float = WINDOW_S) -> None:
        self.window_s = window_s
        self._sent_s = [float("nan")] * RING
        self._newest_sent = 0
        self._echoed = 0  # the newest command seen echoed
        self._trips: deque[tuple[float, float]] = deque()  # (host s, round trip s), trips rising
        self._first_s: float | None = None  # the first echo since reset()

    def reset(self) -> None:
        """The board's stream starts over: nothing before counts."""
        self._trips.clear()
        self._first_s = None
        self._echoed = self._newest_sent

    def sent(self, sequence: int, host_s: float) -> None:
        """Command `sequence` (unwrapped, rising) was counted to go out at host_s."""
        self._sent_s[sequence % RING] = host_s
        self._newest_sent = sequence

    def echoed(self, sequence: int, host_s: float) -> float | None:
        """A sample echoing command `sequence` (unwrapped) arrived at host_s: the window's
        smallest round trip (s) once the window has filled since reset(), else None."""
        if sequence > self._echoed and self._newest_sent - sequence < RING:
            self._echoed = sequence
            trip_s = host_s - self._sent_s[sequence % RING]
            if trip_s >= 0.0:  # NaN (never stamped) fails this too
                trips = self._trips
                while trips and trips[-1][1] >= trip_s:
                    trips.pop()
                trips.append((host_s, trip_s))
                if self._first_s is None:
                    self._first_s = host_s
        return self.estimate(host_s)

    def estimate(self, host_s: float) -> float | None:
        trips = self._trips
        while trips and trips[0][0] < host_s - self.window_s:
            trips.popleft()
        if self._first_s is None or host_s - self._first_s < self.window_s or not trips:
            return None
        return trips[0][1]
