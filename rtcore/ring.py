"""The recording ring in shared memory (csrc/rtcore_ring.c): fixed-width rows of doubles
in a memory-mapped file, one producer (the tick), one consumer (the writer), no lock.

Layout: a header of 8 int64 [magic, n_cols, capacity, count, drained, lost, error,
failed_at], then capacity rows of n_cols float64. `count` is the number of rows ever
pushed; row i lives in slot i % capacity. `drained` is the consumer's progress and `lost`
the rows among them that never reached its file (overwritten before it could read them,
or a write that failed); `error` is the errno of the consumer's first failure (0: none)
and `failed_at` the count when it failed: all published for the producer to watch.

The file is allocated when it is made (posix_fallocate): a full /dev/shm is an OSError
then, never a SIGBUS when a push first touches a page.

The producer writes row `count` into its slot before it publishes `count + 1`, so while
the count reads n the slot of row n - capacity may be half overwritten already: a reader
trusts only the last capacity - 1 rows below the count.
"""

from __future__ import annotations

import contextlib
import functools
import mmap
import os
from pathlib import Path
from typing import Any

import numpy as np

from rtcore._rtcore import ffi, lib

MAGIC = 0x48414E4452494E47  # "HANDRING"
HEADER_INT64 = 8
COUNT, DRAINED, LOST, ERROR, FAILED_AT = 3, 4, 5, 6, 7
TICK_BLOCKS = lib.RTCORE_RING_QUANTITIES  # blocks of one column per finger, after t and state


def row_width(n_fingers: int) -> int:
    """Columns of a tick's row (rtcore_ring_push_tick): t, state, then the blocks."""
    return 2 + TICK_BLOCKS * n_fingers


class Ring:
    def __init__(self, path: str | Path, n_cols: int | None = None, capacity: int | None = None) -> None:
        """Create the ring file when n_cols and capacity are given, else attach to it."""
        self.path = Path(path)
        create = n_cols is not None and capacity is not None
        if create:
            size = 8 * (HEADER_INT64 + capacity * n_cols)
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_EXCL, 0o600)
            try:
                os.posix_fallocate(fd, 0, size)  # every page now, or an OSError (ENOSPC)
            except OSError:
                os.close(fd)
                self.path.unlink(missing_ok=True)
                raise
        else:
            fd = os.open(self.path, os.O_RDWR)
            size = os.fstat(fd).st_size
        try:
            self._map = mmap.mmap(fd, size, mmap.MAP_SHARED, mmap.PROT_READ | mmap.PROT_WRITE)
        finally:
            os.close(fd)
        self.header = np.frombuffer(self._map, dtype=np.int64, count=HEADER_INT64)
        if create:
            self.header[:] = [MAGIC, n_cols, capacity, 0, 0, 0, 0, 0]
        elif self.header[0] != MAGIC:
            raise ValueError(f"{self.path}: not a recording ring")
        self.n_cols, self.capacity = int(self.header[1]), int(self.header[2])
        self.rows = np.frombuffer(self._map, dtype=np.float64, offset=8 * HEADER_INT64,
                                  count=self.n_cols * self.capacity).reshape(self.capacity, self.n_cols)
        header_ptr = ffi.cast("int64_t *", ffi.from_buffer(self.header))
        self._count_ptr = header_ptr + COUNT
        self._rows_ptr = ffi.cast("double *", ffi.from_buffer(self.rows))

    def tick_pusher(self, n_fingers: int, c_inputs: object, c_outputs: object,
                    sent_kpa: np.ndarray, angle_true_deg: Any = None) -> functools.partial:
        """push_tick(t_s, state): the tick's row built in C from the control step's own
        structs (rtcore_ring_push_tick), a single call per tick. angle_true_deg: a `double *`
        to the simulated hand's true angles (the simulator's outputs), None: NaN (a board)."""
        if self.n_cols != row_width(n_fingers):
            raise ValueError(f"a ring of {self.n_cols} columns does not hold {n_fingers} fingers")
        return functools.partial(lib.rtcore_ring_push_tick, self._rows_ptr, self._count_ptr,
                                 self.capacity, self.n_cols, n_fingers, c_inputs, c_outputs,
                                 ffi.cast("double *", ffi.from_buffer(sent_kpa)),
                                 ffi.NULL if angle_true_deg is None else angle_true_deg)

    def publish_to(self, c_tick: Any, n_fingers: int) -> None:
        """Point a tick struct (rtcore_tick) at this ring: the scheduled tick in C
        (rtcore_tick_sim_at) pushes each clean tick's row itself. unpublish() before close."""
        if self.n_cols != row_width(n_fingers) or c_tick.n_fingers != n_fingers:
            raise ValueError(f"a ring of {self.n_cols} columns does not hold the tick's "
                             f"{c_tick.n_fingers} fingers")
        c_tick.ring_count, c_tick.ring_capacity = self._count_ptr, self.capacity
        c_tick.ring_cols, c_tick.ring_rows = self.n_cols, self._rows_ptr

    @staticmethod
    def unpublish(c_tick: Any) -> None:
        """The tick struct pushes into no ring any more."""
        c_tick.ring_rows, c_tick.ring_count = ffi.NULL, ffi.NULL
        c_tick.ring_capacity, c_tick.ring_cols = 0, 0

    @property
    def count(self) -> int:
        return int(lib.rtcore_ring_count(self._count_ptr))

    @property
    def drained(self) -> int:
        return int(self.header[DRAINED])

    @drained.setter
    def drained(self, value: int) -> None:
        self.header[DRAINED] = value

    @property
    def lost(self) -> int:
        return int(self.header[LOST])

    @lost.setter
    def lost(self, value: int) -> None:
        self.header[LOST] = value

    @property
    def error(self) -> int:
        return int(self.header[ERROR])

    @error.setter
    def error(self, value: int) -> None:
        self.header[ERROR] = value

    @property
    def failed_at(self) -> int:
        return int(self.header[FAILED_AT])

    @failed_at.setter
    def failed_at(self, value: int) -> None:
        self.header[FAILED_AT] = value

    def read(self, start: int) -> tuple[np.ndarray, int, int]:
        """Copy the rows from `start` to the current count: (rows, first, lost).

        Rows the producer overwrote before they were read are skipped and counted as lost;
        rows overwritten during the copy are dropped from the copy. Only the last
        capacity - 1 rows below a count are whole: the producer may be writing the next
        row into the slot of the one capacity rows back (see the module's docstring).
        """
        window = self.capacity - 1
        end = self.count
        lost = max(0, end - start - window)
        first = start + lost
        block = self.rows[np.arange(first, end) % self.capacity]  # a copy
        overwritten = self.count - window - first  # slots reused (or being reused) while copying
        if overwritten > 0:
            block = block[overwritten:]
            lost += overwritten
            first += overwritten
        return block, first, lost

    def close(self) -> None:
        self.rows = self.header = None  # type: ignore[assignment]
        self._rows_ptr = self._count_ptr = None
        with contextlib.suppress(BufferError):  # a view is still alive: the mapping goes with it
            self._map.close()
