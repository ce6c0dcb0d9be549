"""Where the recording ring lives, and its allocation in full when a recording starts.

The ring (rtcore.ring) is a file in /dev/shm, mapped by the daemon and the writer. Every
page of it is allocated when it is made (posix_fallocate), so a /dev/shm without room for
it is a one-line error at the start of the recording, never a SIGBUS when a tick first
writes a page of it.
"""

from __future__ import annotations

import os
import tempfile

from hand_service.errors import UserError
from rtcore.ring import HEADER_INT64, Ring

RING_SECONDS = 10.0  # the writer may fall this far behind before rows are lost
RING_DIR_ENV = "HAND_SERVICE_RING_DIR"


def ring_dir() -> str:
    """$HAND_SERVICE_RING_DIR if set, else /dev/shm if writable, else the temporary directory."""
    chosen = os.environ.get(RING_DIR_ENV)
    if chosen:
        if not os.path.isdir(chosen):
            raise UserError(f"{RING_DIR_ENV}={chosen}: not a directory")
        return chosen
    shm = "/dev/shm"
    return shm if os.path.isdir(shm) and os.access(shm, os.W_OK) else tempfile.gettempdir()


def ring_bytes(n_cols: int, capacity: int) -> int:
    return 8 * (HEADER_INT64 + capacity * n_cols)


def allocate_ring(n_cols: int, capacity: int) -> tuple[Ring, str]:
    """A new ring in ring_dir() and its path, every page allocated; a UserError of one line
    if the directory has no room for it."""
    where = ring_dir()
    try:
        fd, ring_path = tempfile.mkstemp(prefix="hand-service-ring-", dir=where)
        os.close(fd)
        os.unlink(ring_path)
        return Ring(ring_path, n_cols, capacity), ring_path
    except OSError as exc:
        raise UserError(
            f"cannot allocate the recording ring ({ring_bytes(n_cols, capacity) / 1024:.0f} KiB, "
            f"{RING_SECONDS:g} s of rows) in {where}: {exc.strerror or exc}; free space there or "
            f"set {RING_DIR_ENV} to a directory with room") from None


__all__ = ["RING_DIR_ENV", "RING_SECONDS", "allocate_ring", "ring_bytes", "ring_dir"]
