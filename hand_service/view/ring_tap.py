"""The daemon's recording ring, read from another process, read-only.

The ring (rtcore/ring.py) is a file in /dev/shm (or $HAND_SERVICE_RING_DIR), mode 0600,
that the daemon and its recording writer both map. Its name stays while the recording
runs and the daemon gives it in its status (`recording.ring_path`), so the view opens it
read-only (O_RDONLY) by that path, as the daemon's user. It only ever reads, with
pread(): it never writes a byte of the ring, takes no lock and sends the daemon nothing,
so the tick cannot wait for it. A recording that stops removes the name; the view's open
file stays readable (the rows no longer advance) until the next status tells it so.

A row is trusted as the recording writer trusts it (rtcore/ring.py): only the last
capacity - 1 rows below a count read after the copy.
"""

from __future__ import annotations

import contextlib
import os
import struct
from pathlib import Path

import numpy as np

RING_MAGIC = 0x48414E4452494E47  # "HANDRING", rtcore/ring.py MAGIC
HEADER_INT64 = 8  # [magic, n_cols, capacity, count, drained, lost, error, failed_at]
COUNT_AT = 3
MAX_BEHIND_S = 2.0  # after a stall a follower catches up with the last 2 s of rows only


class RingGone(Exception):
    """The ring cannot be read (no recording, a recording that stopped, no permission)."""


class RingTap:
    """The rows the daemon pushes, read as they come: read_new() returns the rows pushed
    since the last call (at most the ring's trusted window)."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        try:
            self.fd = os.open(self.path, os.O_RDONLY | os.O_CLOEXEC | os.O_NOFOLLOW)
        except OSError as exc:
            raise RingGone(f"cannot open the recording ring {self.path}: {exc.strerror or exc}") from None
        try:
            header = self._header()
        except RingGone:
            self.close()
            raise
        if header[0] != RING_MAGIC:
            self.close()
            raise RingGone(f"{self.path} is not a recording ring")
        self.n_cols, self.capacity = int(header[1]), int(header[2])
        if not (self.n_cols > 2 and self.capacity > 1):
            self.close()
            raise RingGone(f"the ring {self.path} has {self.n_cols} columns and {self.capacity} rows")
        self.next_row = int(header[COUNT_AT])  # from now on: the view shows what comes
        self.rows_missed = 0  # overwritten before the view read them (it fell a ring behind)

    def _pread(self, size: int, offset: int) -> bytes:
        try:
            data = os.pread(self.fd, size, offset)
        except OSError as exc:
            raise RingGone(f"cannot read the ring {self.path}: {exc.strerror or exc}") from None
        if len(data) != size:
            raise RingGone(f"the ring {self.path} is shorter than its header says")
        return data

    def _header(self) -> tuple[int, ...]:
        return struct.unpack(f"<{HEADER_INT64}q", self._pread(8 * HEADER_INT64, 0))

    def count(self) -> int:
        """Rows ever pushed."""
        return struct.unpack("<q", self._pread(8, 8 * COUNT_AT))[0]

    def read_new(self, max_rows: int | None = None) -> tuple[np.ndarray, int]:
        """(rows, first): the rows pushed since the last call, oldest first, as an
        (n, n_cols) array, and the index of the first (rows ever pushed before it); the
        newest max_rows only when given (the older ones count as missed)."""
        window = self.capacity - 1
        end = self.count()
        first = max(self.next_row, end - window)
        if max_rows is not None:
            first = max(first, end - max_rows)
        self.rows_missed += first - self.next_row
        if end <= first:
            self.next_row = max(self.next_row, end)
            return np.empty((0, self.n_cols)), end
        slots = np.arange(first, end) % self.capacity
        rows = np.empty((end - first, self.n_cols))
        row_bytes = 8 * self.n_cols
        data_at = 8 * HEADER_INT64
        # contiguous runs of slots: one pread each (two at most, where the ring wraps)
        breaks = np.flatnonzero(np.diff(slots) != 1) + 1
        for run in np.split(np.arange(slots.size), breaks):
            if run.size == 0:
                continue
            raw = self._pread(row_bytes * run.size, data_at + row_bytes * int(slots[run[0]]))
            rows[run] = np.frombuffer(raw, dtype="<f8").reshape(run.size, self.n_cols)
        # a slot the producer reused while we copied: drop it, as rtcore/ring.py does
        overwritten = self.count() - window - first
        if overwritten > 0:
            rows = rows[overwritten:]
            self.rows_missed += overwritten
            first += overwritten
        self.next_row = end
        return rows, first

    def close(self) -> None:
        with contextlib.suppress(OSError):
            os.close(self.fd)


class RingFollower:
    """The ring a daemon's status names, followed: opened while the status says it records,
    opened again when the name changes, closed when the recording stops or the ring is gone.
    After a stall only the newest `max_behind_s` of rows are read (the older count as missed)."""

    def __init__(self, max_behind_s: float = MAX_BEHIND_S) -> None:
        self.max_behind_s = max_behind_s
        self.tap: RingTap | None = None
        self.note: str | None = None  # why no ring is followed, when it is not
        self._max_rows = 1

    def follow(self, ring_path: str | None, rate_hz: float) -> bool:
        """Follow the ring at `ring_path` (None: no recording); True when a ring was opened
        now (the caller sets up what depends on the fingers and rate)."""
        if ring_path is None:
            self.close()
            return False
        if self.tap is not None and str(self.tap.path) == ring_path:
            return False
        self.close()
        try:
            self.tap = RingTap(ring_path)
        except RingGone as exc:
            self.note = str(exc)
            return False
        self._max_rows = max(1, int(self.max_behind_s * rate_hz))
        self.note = None
        return True

    def read_new(self) -> tuple[np.ndarray, int] | None:
        """The rows pushed since the last call and the first's index, or None when no ring is
        followed (a ring that went away between two statuses is closed, `note` says why)."""
        if self.tap is None:
            return None
        try:
            return self.tap.read_new(max_rows=self._max_rows)
        except RingGone as exc:
            self.note = str(exc)
            self.close()
            return None

    @property
    def rows_missed(self) -> int:
        return 0 if self.tap is None else self.tap.rows_missed

    def close(self) -> None:
        if self.tap is not None:
            self.tap.close()
        self.tap = None


__all__ = ["RingFollower", "RingGone", "RingTap"]
