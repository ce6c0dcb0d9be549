"""The host's own stalls, seen from the bus transport's reader thread.

The reader turns at least every READ_TIMEOUT_S (link.py): a longer gap between two turns
is time the host did not run it (a busy machine, a page fault, a stop signal), not time
the link was slow. Over such a stall the board went on sampling; its samples wait in the
port or the bus queue, and arrive in a burst when the reader runs again, each as old as
the stall made it. Judged as the link's, they would read as late samples (`sample_late`)
and, where a queue overflowed, as lost ones (`sample_loss`, `stale_sensor`): a FAULT and a
vent for a stall the board rode through safely on its own watchdog.

A stall no longer than safety.host_stall_max_ms (shorter than the board's watchdog, so the
board kept applying the last command) is ridden through: for the stall's length again
after it (the burst, and a sample period or two for the link to catch up), the age the
checks judge is the sample's age less the stall, and samples lost are the host's, not
counted against the link. It is counted and logged, once per stall. A longer stall is not
ridden through: the checks judge it as they always did (and the board's watchdog has
vented, which the supervisor hears as firmware_vented).
"""

from __future__ import annotations

from dataclasses import dataclass

READ_TIMEOUT_S = 0.01  # the reader waits this long at most for a frame (link.py)
# a reader gap this much longer than its read timeout is a stall of the host
STALL_MIN_S = 0.02


@dataclass
class Stall:
    started_s: float
    length_s: float
    ridden: bool  # within host_stall_max_ms


class HostStalls:
    """The reader's turns, its stalls, and the grace after one it rides through."""

    def __init__(self, read_timeout_s: float, ride_max_s: float, period_s: float) -> None:
        self.expected_s = read_timeout_s + STALL_MIN_S
        self.ride_max_s = ride_max_s
        self.period_s = period_s
        self.count = 0  # stalls ridden through
        self.worst_s = 0.0  # the longest ridden through
        self.lost = 0  # board samples lost in ridden stalls' grace
        self.beyond = 0  # stalls longer than host_stall_max_ms: not ridden through
        self.worst_beyond_s = 0.0
        self._last_turn_s: float | None = None
        self._grace_until_s = -1.0
        self._excused_s = 0.0  # the stall the grace excuses, subtracted from ages

    def reset(self) -> None:
        self._last_turn_s = None
        self._grace_until_s = -1.0
        self._excused_s = 0.0

    def turn(self, host_s: float) -> Stall | None:
        """The reader turns at host_s: the stall before it, if there was one."""
        last, self._last_turn_s = self._last_turn_s, host_s
        if last is None:
            return None
        gap_s = host_s - last
        if gap_s <= self.expected_s:
            return None
        stall = Stall(last, gap_s, gap_s <= self.ride_max_s)
        if not stall.ridden:
            self.beyond += 1
            self.worst_beyond_s = max(self.worst_beyond_s, gap_s)
        else:
            self.count += 1
            self.worst_s = max(self.worst_s, gap_s)
            self._excused_s = gap_s
            self._grace_until_s = host_s + gap_s + 2 * self.period_s
        return stall

    def excused_s(self, host_s: float) -> float:
        """How much of a sample's age at host_s is the host's own stall (0: none)."""
        return self._excused_s if host_s <= self._grace_until_s else 0.0
