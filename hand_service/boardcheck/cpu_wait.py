"""How long this thread has waited for a CPU: its own wake-up delays, as the kernel counts them.

Linux keeps, per thread, the time it spent runnable but not running (the second field of
/proc/thread-self/schedstat, in ns): a wake-up that waited for a busy core, a preemption.
The difference over a stretch of board-check's loop is how much later than the board's
data it ran, which is board-check's delay and not the board's. Where the file is missing
(not Linux, schedstats off) `waited_s` is None, and the session falls back to timing its
own waits (session.py).
"""

from __future__ import annotations

from pathlib import Path

SCHEDSTAT = Path("/proc/thread-self/schedstat")


class CpuWait:
    """Reads the calling thread's run-queue time; make it in the thread it measures."""

    def __init__(self, path: Path = SCHEDSTAT) -> None:
        try:
            self._file = path.open("rb", buffering=0)
            self._file.read()  # the file must also be readable, not only present
        except OSError:
            self._file = None

    @property
    def available(self) -> bool:
        return self._file is not None

    def waited_s(self) -> float | None:
        """The thread's total time runnable but not running, in s (None: not measurable)."""
        if self._file is None:
            return None
        self._file.seek(0)
        fields = self._file.read().split()
        return int(fields[1]) / 1e9 if len(fields) > 1 else None

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None
