"""The daemon's recording ring, read from another process, read-only.

The ring (rtcore/ring.py) is a file in /dev/shm that the daemon and its recording writer
both map; the writer unlinks it as soon as it has mapped it, so no path names it any more.
The viewer finds it among the writer's mappings (/proc/PID/maps, a `hand-service-ring-`
file marked deleted) and opens that mapping through /proc/PID/map_files (the file itself;
root or CAP_CHECKPOINT_RESTORE) or, failing that, reads it through /proc/PID/mem (the
writer is the viewer's user's process). Either way it only ever reads, with pread(): it
never writes a byte of the ring, takes no lock and sends the daemon nothing, so the tick
cannot wait for it. It reads the writer's address space, not the daemon's.

A row is trusted as the recording writer trusts it (rtcore/ring.py): only the last
capacity - 1 rows below a count read after the copy.
"""

from __future__ import annotations

import contextlib
import os
import struct
from dataclasses import dataclass

import numpy as np

RING_MAGIC = 0x48414E4452494E47  # "HANDRING", rtcore/ring.py MAGIC
HEADER_INT64 = 8  # [magic, n_cols, capacity, count, drained, lost, error, failed_at]
COUNT_AT = 3
RING_NAME = "hand-service-ring-"


class RingGone(Exception):
    """The ring cannot be read (no writer, a recording that stopped, no permission)."""


@dataclass
class RingMapping:
    """Where the ring lies in the writer process: a file to pread and the ring's offset in it."""

    fd: int
    base: int  # byte offset of the ring's header in fd
    how: str  # "map_files" or "mem"


def find_mapping(pid: int) -> tuple[int, int]:
    """(start, end) addresses of the ring's mapping in process `pid`; RingGone if it has none."""
    try:
        with open(f"/proc/{pid}/maps", encoding="ascii", errors="replace") as maps:
            for line in maps:
                fields = line.split(maxsplit=5)
                if len(fields) == 6 and RING_NAME in fields[5] and fields[1].endswith("s"):
                    start, end = (int(a, 16) for a in fields[0].split("-"))
                    return start, end
    except OSError as exc:
        raise RingGone(f"cannot read the mappings of the recording writer (pid {pid}): "
                       f"{exc.strerror or exc}") from None
    raise RingGone(f"the recording writer (pid {pid}) has no ring mapped")


WAYS = ("map_files", "mem")


def open_mapping(pid: int, ways: tuple[str, ...] = WAYS) -> RingMapping:
    """The ring of writer `pid`, opened read-only the first of `ways` that works; RingGone
    with the reason if none does."""
    start, end = find_mapping(pid)
    if "map_files" in ways:
        with contextlib.suppress(OSError):
            fd = os.open(f"/proc/{pid}/map_files/{start:x}-{end:x}", os.O_RDONLY | os.O_CLOEXEC)
            return RingMapping(fd, 0, "map_files")
    if "mem" not in ways:
        raise RingGone(f"cannot open the ring's mapping of the recording writer (pid {pid})")
    try:
        fd = os.open(f"/proc/{pid}/mem", os.O_RDONLY | os.O_CLOEXEC)
    except OSError as exc:
        raise RingGone(f"cannot read the recording writer's memory (pid {pid}): "
                       f"{exc.strerror or exc}") from None
    return RingMapping(fd, start, "mem")


class RingTap:
    """The rows the daemon pushes, read as they come: read_new() returns the rows pushed
    since the last call (at most the ring's trusted window)."""

    def __init__(self, pid: int, ways: tuple[str, ...] = WAYS) -> None:
        self.pid = pid
        self.mapping = open_mapping(pid, ways)
        try:
            header = self._header()
        except RingGone:
            self.close()
            raise
        if header[0] != RING_MAGIC:
            self.close()
            raise RingGone(f"the mapping of pid {pid} is not a recording ring")
        self.n_cols, self.capacity = int(header[1]), int(header[2])
        if not (self.n_cols > 2 and self.capacity > 1):
            self.close()
            raise RingGone(f"the ring of pid {pid} has {self.n_cols} columns and {self.capacity} rows")
        self.next_row = int(header[COUNT_AT])  # from now on: the view shows what comes
        self.rows_missed = 0  # overwritten before the view read them (it fell a ring behind)

    def _pread(self, size: int, offset: int) -> bytes:
        try:
            data = os.pread(self.mapping.fd, size, self.mapping.base + offset)
        except OSError as exc:  # the writer exited and its memory went with it
            raise RingGone(f"the ring of pid {self.pid} is gone: {exc.strerror or exc}") from None
        if len(data) != size:
            raise RingGone(f"the ring of pid {self.pid} is gone (short read)")
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
            os.close(self.mapping.fd)


__all__ = ["WAYS", "RingGone", "RingMapping", "RingTap", "find_mapping", "open_mapping"]
