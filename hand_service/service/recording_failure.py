"""A recording that stopped reaching its file, and the counts of its rows.

The writer (recorder_writer) publishes in the ring's header how far it drained, the rows
among them it lost and, last, the errno of a failed write; the daemon also finds a
writer that died. After either nothing more reaches the file, so every row pushed and
not written is lost, and the counts are exact at once.
"""

from __future__ import annotations

import errno as errno_names
import os
import signal
from dataclasses import dataclass
from pathlib import Path

from rtcore.ring import Ring


@dataclass(frozen=True)
class RecordingFailure:
    """Why a recording stopped reaching its file, and when (in rows: one per tick)."""

    path: Path
    reason: str  # "No space left on device (ENOSPC)", "its writer was killed by SIGKILL"
    errno: int | None  # of the failed write; None for a writer that died
    at_row: int  # the ring's count when the write failed (when the daemon found a dead writer)
    seen_at_row: int  # the ring's count on the tick that saw it
    seen_t_s: float | None  # that tick's time (s since the loop started); None: found at the stop

    def describe(self) -> str:
        return (f"recording {self.path} failed at row {self.at_row}: {self.reason}; nothing more "
                "is written to it, and every row from now on counts as lost (rows_lost)")

    def as_dict(self) -> dict[str, object]:
        return {"reason": self.reason, "errno": self.errno, "at_row": self.at_row,
                "seen_at_row": self.seen_at_row,
                "seen_t_s": None if self.seen_t_s is None else round(self.seen_t_s, 4)}


def write_error(path: Path, ring: Ring, seen_at_row: int, t_s: float | None) -> RecordingFailure | None:
    """The failed write the writer published in the ring's header, or None."""
    code = ring.error
    if code == 0:
        return None
    name = errno_names.errorcode.get(code, str(code))
    return RecordingFailure(path, f"{os.strerror(code)} ({name})", code, ring.failed_at, seen_at_row, t_s)


def writer_gone(path: Path, returncode: int | None, seen_at_row: int,
                t_s: float | None) -> RecordingFailure:
    """A writer that ended while the recording ran (returncode: the process's, None for a thread)."""
    if returncode is None:
        reason = "its writer thread ended (its error is on stderr)"
    elif returncode < 0:
        try:
            reason = f"its writer was killed by {signal.Signals(-returncode).name}"
        except ValueError:
            reason = f"its writer was killed by signal {-returncode}"
    else:
        reason = f"its writer exited with status {returncode}"
    return RecordingFailure(path, reason, None, seen_at_row, seen_at_row, t_s)


def row_counts(ring: Ring, rows: int, failed: bool) -> dict[str, int]:
    """rows (pushed), rows_written (in the file), rows_lost and lag_rows (still in the
    ring); they add up to rows. `failed`: nothing more will be written (read ring.error
    before this: the writer published drained and lost before it), so every row not
    written is lost. Else lost is read before drained, which the writer publishes first,
    so that rows_written is never negative."""
    lost = ring.lost
    drained = ring.drained
    written = drained - lost
    if failed:
        return {"rows": rows, "rows_written": written, "rows_lost": rows - written, "lag_rows": 0}
    return {"rows": rows, "rows_written": written, "rows_lost": lost, "lag_rows": rows - drained}


__all__ = ["RecordingFailure", "row_counts", "write_error", "writer_gone"]
