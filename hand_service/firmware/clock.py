"""The mock firmware's own clock: the machine's monotonic clock, or one that drifts from it.

A board keeps time with its own oscillator; a crystal is good to tens of ppm, an RC
oscillator to a percent or two. The mock reads this clock for everything it times
(samples, watchdog, status uptime, fault durations), so a drift injected on its debug
port (FaultKind.CLOCK_DRIFT) moves all of them together, as a real board's would.
"""

from __future__ import annotations

import time

PPM = 1e-6


class BoardClock:
    """Seconds on the board's clock; `rate` board seconds pass per host second."""

    def __init__(self) -> None:
        self.rate = 1.0
        self._host0_s = self._board0_s = time.monotonic()

    def now(self) -> float:
        return self._board0_s + (time.monotonic() - self._host0_s) * self.rate

    def set_drift_ppm(self, drift_ppm: float) -> None:
        """From now on the board's clock runs fast by drift_ppm (slow when negative)."""
        rate = 1.0 + drift_ppm * PPM
        if rate != self.rate:
            board_s = self.now()
            self._host0_s, self._board0_s, self.rate = time.monotonic(), board_s, rate

    def host_seconds(self, board_s: float) -> float:
        """How long board_s of the board's time takes on the host's clock."""
        return board_s / self.rate
