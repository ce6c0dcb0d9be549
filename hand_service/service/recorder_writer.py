"""The recording writer: drains the ring (rtcore.ring) into the CSV of docs/formats.md.

It runs as its own process by default (`python -m hand_service.service.recorder_writer`), so that
formatting text never holds the daemon's GIL; the same Drainer can run as a thread in
the daemon, to measure what that costs (`bench --recorder thread`).

Protocol with the daemon on the writer's stdin: `flush` drains and flushes now, `stop`
drains, closes and exits; end of file (the daemon died, even by SIGKILL) does the same
as stop, so a crash loses nothing the tick had pushed. Between commands it drains and
flushes to the OS every FLUSH_INTERVAL_S: what a crash of both processes can lose. It
fdatasyncs (the rows and the file size) on `flush` (faults, signals) and at the end, and
every --sync-every-s only if asked: on a virtual machine the disk flush can stop every
vCPU for 10-20 ms, a deadline miss of the tick (docs/service.md, "Recording").
"""

from __future__ import annotations

import argparse
import os
import select
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import IO

import numpy as np

from hand_service.service.states import State
from rtcore.config import MODE_FORCE, MODE_NAMES, MODE_POSITION
from rtcore.ring import Ring

FLUSH_INTERVAL_S = 0.2
# The state column: the supervisor's state, and one more for the last row of a daemon
# that stops, the tick that vented every finger (Supervisor.shutdown): the file says so,
# whatever state the loop was in when it stopped.
SHUTDOWN_STATE = max(State) + 1
STATE_NAMES = (*(s.name for s in State), "SHUTDOWN")

# The ring row: t, state, then one block of n_fingers per quantity, in this order.
QUANTITIES = ("angle_ref_deg", "pressure_kpa", "pressure_meas_kpa", "angle_deg", "angle_filt_deg",
              "velocity_deg_per_s", "force_est_n", "force_ref_n", "mode", "flags")
HEAD = ("t", "state")


def ring_columns(n_fingers: int) -> int:
    return len(HEAD) + len(QUANTITIES) * n_fingers


def csv_header(fingers: list[str]) -> list[str]:
    """The CSV's columns: t, state, then every quantity of each finger, suffixed."""
    return [*HEAD, *(f"{q}_{f}" for f in fingers for q in QUANTITIES)]


class Drainer:
    """Ring rows -> CSV lines, appended to an open file."""

    def __init__(self, ring: Ring, out: IO[str], fingers: list[str],
                 sync_every_s: float | None = None) -> None:
        """sync_every_s: also fdatasync when that long has passed since the last (default:
        only when flush(sync=True) asks)."""
        self.ring, self.out, self.fingers = ring, out, fingers
        self.sync_every_s = sync_every_s
        n = len(fingers)
        # CSV order (finger-major) from the ring's quantity-major blocks
        self.order = np.array([len(HEAD) + q * n + f for f in range(n) for q in range(len(QUANTITIES))])
        self.next_row = 0  # the ring is new: from its first row
        self.rows_written = 0
        self.rows_lost = 0
        self._last_sync = time.monotonic()
        mode_at, flags_at = QUANTITIES.index("mode"), QUANTITIES.index("flags")
        self._kinds = [("mode" if q == mode_at else "flags" if q == flags_at else "num")
                       for _ in fingers for q in range(len(QUANTITIES))]
        # positions in the CSV order: a reference is written only under its mode
        width = len(QUANTITIES)
        self._mode = np.arange(n) * width + mode_at
        self._angle_ref = np.arange(n) * width + QUANTITIES.index("angle_ref_deg")
        self._force_ref = np.arange(n) * width + QUANTITIES.index("force_ref_n")

    def _line(self, row: np.ndarray) -> str:
        cells = [f"{row[0]:.4f}", STATE_NAMES[int(row[1])] if 0 <= row[1] < len(STATE_NAMES) else "?"]
        values = row[self.order]
        mode = values[self._mode]
        values[self._angle_ref[mode != MODE_POSITION]] = np.nan
        values[self._force_ref[mode != MODE_FORCE]] = np.nan
        for kind, value in zip(self._kinds, values, strict=True):
            if kind == "num":
                cells.append(f"{value:.6g}")
            elif kind == "mode":
                cells.append(MODE_NAMES.get(int(value), "?"))
            else:
                cells.append(str(int(value)))
        return ",".join(cells)

    def drain(self) -> int:
        """Write every row pushed since the last drain; returns how many."""
        block, first, lost = self.ring.read(self.next_row)
        if lost:
            self.rows_lost += lost
            self.out.write(f"# lost: {lost} rows before row {first} (the writer fell behind)\n")
        if len(block):
            self.out.write("\n".join(self._line(row) for row in block) + "\n")
        self.next_row = first + len(block)
        # published in the ring's header for the daemon: drained, then lost, which the
        # daemon reads in the other order (Recorder.status), so that rows_written =
        # drained - lost is never negative
        self.ring.drained = self.next_row
        self.ring.lost = self.rows_lost
        self.rows_written += len(block)
        return len(block)

    def flush(self, sync: bool = False) -> None:
        self.drain()
        self.out.flush()
        now = time.monotonic()
        if sync or (self.sync_every_s is not None and now - self._last_sync >= self.sync_every_s):
            os.fdatasync(self.out.fileno())
            self._last_sync = now


class WriterThread:
    """The Drainer as a thread of the daemon: measured against the process, not the default."""

    def __init__(self, drainer: Drainer) -> None:
        self.drainer = drainer
        self._wake = threading.Event()
        self._sync = False  # flush() asked for an fdatasync (a fault, a signal)
        self._stop = False
        self._lock = threading.Lock()
        self._ended = False
        self._closers: list[Callable[[], None]] = []  # left to it by leave()
        self._thread = threading.Thread(target=self._run, name="recorder-writer", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        try:
            while True:
                self._wake.wait(FLUSH_INTERVAL_S)
                self._wake.clear()
                sync, self._sync = self._sync, False
                self.drainer.flush(sync=sync)
                if self._stop:
                    self.drainer.flush(sync=True)
                    return
        finally:
            with self._lock:
                self._ended = True
                closers, self._closers = self._closers, []
            for close in closers:
                close()

    def leave(self, *closers: Callable[[], None]) -> None:
        """What to close once it no longer reads (its file, the ring): closed by the
        thread as it ends, or here at once if it has ended already."""
        with self._lock:
            if not self._ended:
                self._closers.extend(closers)
                return
        for close in closers:
            close()

    def flush(self) -> None:
        """Drain, flush and fdatasync now (as the process writer's `flush` command)."""
        self._sync = True
        self._wake.set()

    def request_stop(self) -> None:
        """Drain, fsync and end, without waiting for it (join() or done)."""
        self._stop = True
        self._wake.set()

    def join(self, timeout_s: float) -> bool:
        self._thread.join(timeout_s)
        return self.done

    @property
    def done(self) -> bool:
        return not self._thread.is_alive()


def serve(ring: Ring, csv_path: Path, fingers: list[str], commands_fd: int, replies: IO[str],
          sync_every_s: float | None = None) -> int:
    with open(csv_path, "a") as out:
        drainer = Drainer(ring, out, fingers, sync_every_s)
        replies.write("ready\n")
        replies.flush()
        while True:
            readable, _, _ = select.select([commands_fd], [], [], FLUSH_INTERVAL_S)
            data = os.read(commands_fd, 4096) if readable else b"tick"
            commands = data.split()
            if not data or b"stop" in commands:  # no data: end of file, the daemon is gone
                drainer.flush(sync=True)
                return 0
            drainer.flush(sync=b"flush" in commands)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description="drain a recording ring into a CSV (run by the daemon)")
    parser.add_argument("ring", type=Path)
    parser.add_argument("csv", type=Path)
    parser.add_argument("--fingers", required=True, help="comma-separated finger names")
    parser.add_argument("--sync-every-s", type=float, default=None, metavar="S",
                        help="also fdatasync every S seconds (default: on flush and at the end only)")
    args = parser.parse_args(argv)
    ring = Ring(args.ring)
    args.ring.unlink(missing_ok=True)  # both ends have it mapped: nothing is left behind
    return serve(ring, args.csv, args.fingers.split(","), sys.stdin.fileno(), sys.stdout, args.sync_every_s)


if __name__ == "__main__":
    sys.exit(main())
