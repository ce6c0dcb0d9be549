"""Where the recording ring lives, and its allocation in full when a recording starts.

The ring (rtcore.ring) is a file in /dev/shm ($HAND_SERVICE_RING_DIR if set), mode 0600,
mapped by the daemon and the writer. Every page of it is allocated when it is made
(posix_fallocate), so a /dev/shm without room for it is a one-line error at the start of
the recording, never a SIGBUS when a tick first writes a page of it.

Its name stays while the recording runs, so that a reader of the same user (the live
view, docs/view.md) opens it read-only by the path the recorder's status gives
(`ring_path`). The daemon removes the name when the recording stops, and the writer
process when it exits (the daemon may have died); the mappings live on without it. The
name carries the daemon's pid, `hand-service-ring-PID-XXXXXXXX`: a ring left by a daemon
and a writer that were both killed is removed by the next recording of that user.
"""

from __future__ import annotations

import contextlib
import os
import re
import tempfile
from pathlib import Path

from hand_service.errors import UserError
from rtcore.ring import HEADER_INT64, Ring

RING_SECONDS = 10.0  # the writer may fall this far behind before rows are lost
RING_DIR_ENV = "HAND_SERVICE_RING_DIR"
RING_PREFIX = "hand-service-ring-"
_OWNED_BY = re.compile(re.escape(RING_PREFIX) + r"(\d+)-")


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


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process
        return True
    return True


def remove_stale_rings(where: str) -> list[Path]:
    """Remove this user's rings in `where` whose daemon is gone (both it and its writer
    were killed before either could remove the name); the paths removed."""
    removed = []
    with contextlib.suppress(OSError):
        for entry in os.scandir(where):
            found = _OWNED_BY.match(entry.name)
            if found is None or _alive(int(found.group(1))):
                continue
            with contextlib.suppress(OSError):
                if entry.stat(follow_symlinks=False).st_uid == os.geteuid() and entry.is_file(
                        follow_symlinks=False):
                    os.unlink(entry.path)
                    removed.append(Path(entry.path))
    return removed


def allocate_ring(n_cols: int, capacity: int) -> tuple[Ring, str]:
    """A new ring in ring_dir() and its path, every page allocated, mode 0600; a UserError
    of one line if the directory has no room for it."""
    where = ring_dir()
    remove_stale_rings(where)
    try:
        fd, ring_path = tempfile.mkstemp(prefix=f"{RING_PREFIX}{os.getpid()}-", dir=where)
        os.close(fd)
        os.unlink(ring_path)
        return Ring(ring_path, n_cols, capacity), ring_path
    except OSError as exc:
        raise UserError(
            f"cannot allocate the recording ring ({ring_bytes(n_cols, capacity) / 1024:.0f} KiB, "
            f"{RING_SECONDS:g} s of rows) in {where}: {exc.strerror or exc}; free space there or "
            f"set {RING_DIR_ENV} to a directory with room") from None


__all__ = ["RING_DIR_ENV", "RING_PREFIX", "RING_SECONDS", "allocate_ring", "remove_stale_rings", "ring_bytes",
           "ring_dir"]
