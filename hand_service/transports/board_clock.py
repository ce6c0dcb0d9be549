"""The board's clock seen from the host: how old a sample is, and how fast the board's time runs.

The board stamps what it sends with its own time: a sample with its sequence (one per
sample period on the board's clock, lost ones included: the monitor unwraps the 8-bit
counter), a status with its uptime in ms. The host stamps each on arrival with its
monotonic clock. Their difference, host minus board, is the link's delay plus a constant
offset between the clocks; the smallest difference seen is the offset plus the fastest
the link ever was, so a sample's age is its difference less that smallest one (an
NTP-like estimate). Over a sliding window, so that a board clock that runs slow does not
look like a growing delay forever.

The slope of the smallest differences, window by window, is the drift between the
clocks. It is taken from the status uptime, not the samples: a board that skips a sample
(a stalled mock on a busy machine) loses sample periods, never uptime. A delay only ever
adds to the difference, so the line is the one below every window's smallest difference
that comes closest to them (Moon, Skelly and Towsley's linear-programming skew estimate:
the edge of their lower convex hull over their mean time). A window whose every status
came late (a loaded machine: a mock firmware, or the host's reader, behind for a whole
second) lies above that line and does not tilt it, where the slope from the first window to
the last would read a late last window as a drift.
"""

from __future__ import annotations

import itertools
import math
from collections import deque

AGE_WINDOW_S = 2.0  # the smallest host-board difference over this long is the offset
DRIFT_WINDOW_S = 1.0  # the drift is the slope of the smallest differences of such windows
DRIFT_WINDOWS = 6  # ... from the oldest of this many to the newest (the newest may be partial)
# Judged only over at least this long: on a loaded machine a mock firmware (or a board's
# USB link) can be late for a whole window, and a few ms late over a span of 1-2 s reads as
# thousands of ppm; the longer span divides that delay by its length.
DRIFT_MIN_SPAN_S = 3.0


class SampleAge:
    """The age of samples on the board's clock: index × period is when the board took it."""

    def __init__(self, period_s: float, window_s: float = AGE_WINDOW_S) -> None:
        self.period_s = period_s
        self.window_s = window_s
        self._lows: deque[tuple[float, float]] = deque()  # (host s, difference s), differences rising
        self._newest_board_s: float | None = None

    def reset(self) -> None:
        """The board's count starts over (a reconnect, a reboot)."""
        self._lows.clear()
        self._newest_board_s = None

    def sample(self, index: int, host_s: float) -> float:
        """A sample the board took as its index-th arrived at host_s: its age (s)."""
        board_s = index * self.period_s
        difference = host_s - board_s
        lows = self._lows
        while lows and lows[-1][1] >= difference:
            lows.pop()
        lows.append((host_s, difference))
        while lows[0][0] < host_s - self.window_s:
            lows.popleft()
        self._newest_board_s = board_s
        return difference - lows[0][1]

    def age_now(self, host_s: float) -> float | None:
        """How old the newest sample would be if it were handed on at host_s (None: none yet).
        It grows while nothing arrives: a delayed link shows before its late samples do."""
        if self._newest_board_s is None or not self._lows:
            return None
        return host_s - self._newest_board_s - self._lows[0][1]


class ClockDrift:
    """How fast the board's clock runs against the host's, in ppm (fast: positive)."""

    def __init__(self, window_s: float = DRIFT_WINDOW_S, windows: int = DRIFT_WINDOWS) -> None:
        self.window_s = window_s
        self.windows = windows
        self._lows: deque[tuple[int, float, float]] = deque()  # (window, host s, difference s)
        self._start_s: float | None = None

    def reset(self) -> None:
        self._lows.clear()
        self._start_s = None

    def status(self, uptime_s: float, host_s: float) -> float | None:
        """A status stamped uptime_s on the board arrived at host_s: the drift (ppm), once
        the windows span at least DRIFT_MIN_SPAN_S, else None."""
        if self._start_s is None:
            self._start_s = host_s
        window = math.floor((host_s - self._start_s) / self.window_s)
        difference = host_s - uptime_s
        lows = self._lows
        if lows and lows[-1][0] == window:
            if difference < lows[-1][2]:
                lows[-1] = (window, host_s, difference)
        else:
            lows.append((window, host_s, difference))
            while len(lows) > self.windows:
                lows.popleft()
        if lows[-1][1] - lows[0][1] < DRIFT_MIN_SPAN_S:
            return None
        # host - board falls when the board's clock runs fast
        return -lower_slope([(host_s, difference) for _, host_s, difference in lows]) * 1e6


def lower_slope(points: list[tuple[float, float]]) -> float:
    """The slope of the line below every point (x rising) that is closest to them in sum:
    the edge of their lower convex hull over the points' mean x."""
    hull: list[tuple[float, float]] = []
    for x, y in points:  # Andrew's monotone chain, the lower half
        while len(hull) >= 2 and ((hull[-1][0] - hull[-2][0]) * (y - hull[-2][1])
                                  - (hull[-1][1] - hull[-2][1]) * (x - hull[-2][0])) <= 0.0:
            hull.pop()
        hull.append((x, y))
    mean_x = sum(x for x, _ in points) / len(points)
    # the hull ends at the last point, at or past the mean: some edge reaches it
    return next((y1 - y0) / (x1 - x0) for (x0, y0), (x1, y1) in itertools.pairwise(hull) if x1 >= mean_x)
