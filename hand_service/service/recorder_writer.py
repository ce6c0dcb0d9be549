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

Rows go to the file through its descriptor, unbuffered, one write per drain. A write that
fails (a full disk: ENOSPC, a file-size limit: EFBIG, an I/O error) ends the recording's
writing: a row it cut short is cut off the file again, so the file holds whole rows
only, and the writer publishes in the ring's header the rows it wrote and, last, the
errno and the count it failed at. The daemon reads that errno every tick (Recorder.check):
the failure is in its status and its log on the next tick. From then the writer writes
nothing more, so the daemon counts every row pushed and not written as lost, exactly.
"""

from __future__ import annotations

import argparse
import errno
import io
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

# The ring row: t, state, then one block of n_fingers per quantity, in this order
# (csrc/rtcore_ring.c). angle_true_deg, the simulated hand's true angle (NaN from a board),
# came last, so that the blocks before it kept their places.
QUANTITIES = ("angle_ref_deg", "pressure_kpa", "pressure_meas_kpa", "angle_deg", "angle_filt_deg",
              "velocity_deg_per_s", "force_est_n", "force_ref_n", "mode", "flags", "angle_true_deg")
HEAD = ("t", "state")


def ring_columns(n_fingers: int) -> int:
    return len(HEAD) + len(QUANTITIES) * n_fingers


def csv_header(fingers: list[str]) -> list[str]:
    """The CSV's columns: t, state, then every quantity of each finger, suffixed."""
    return [*HEAD, *(f"{q}_{f}" for f in fingers for q in QUANTITIES)]


class Drainer:
    """Ring rows -> CSV lines, appended to an open file (through its descriptor), or to an
    in-memory text stream (tests)."""

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
        self.rows_lost = 0  # overwritten before they were read, or not written by a failed write
        self.error: OSError | None = None  # the first failure: nothing is written after it
        try:
            self._fd: int | None = out.fileno()
        except (AttributeError, io.UnsupportedOperation):
            self._fd = None
        self._size = os.fstat(self._fd).st_size if self._fd is not None else 0  # whole rows end here
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
        """Write every row pushed since the last drain; returns how many reached the file
        (none once a write has failed)."""
        if self.error is not None:
            return 0
        block, first, lost = self.ring.read(self.next_row)
        lines = [f"# lost: {lost} rows before row {first} (the writer fell behind)"] if lost else []
        lines.extend(self._line(row) for row in block)
        whole = self._append(lines) if lines else 0
        written = whole - 1 if lost and whole else whole  # the `# lost` line is not a row
        self.rows_lost += lost + len(block) - written
        self.next_row = first + len(block)
        self.rows_written += written
        self._publish()
        return written

    def _append(self, lines: list[str]) -> int:
        """Append the lines in one write; how many reached the file whole. A write that
        fails part way is cut back to its last whole line."""
        text = "\n".join(lines) + "\n"
        if self._fd is None:
            self.out.write(text)
            return len(lines)
        data = memoryview(text.encode())
        done = 0
        try:
            while done < len(data):
                wrote = os.write(self._fd, data[done:])
                if wrote == 0:
                    raise OSError(errno.EIO, "the write wrote nothing")
                done += wrote
        except OSError as exc:
            whole = bytes(data[:done]).rfind(b"\n") + 1
            if whole < done:  # a row cut short: off the file again, it holds whole rows only
                try:
                    os.ftruncate(self._fd, self._size + whole)
                except OSError as cut:
                    print(f"recording writer: cannot cut a partial row off the file: {cut}",
                          file=sys.stderr)
            self._size += whole
            self._fail(exc)
            return bytes(data[:whole]).count(b"\n")
        self._size += done
        return len(lines)

    def _fail(self, exc: OSError) -> None:
        if self.error is None:
            self.error = exc
            self.ring.failed_at = self.ring.count

    def _publish(self) -> None:
        """Into the ring's header for the daemon: drained, then lost, which the daemon reads
        in the other order (Recorder.status), so that rows_written = drained - lost is never
        negative; the errno of a failure last, so that the daemon that sees it reads the
        final drained and lost."""
        self.ring.drained = self.next_row
        self.ring.lost = self.rows_lost
        if self.error is not None:
            self.ring.error = self.error.errno or errno.EIO

    def flush(self, sync: bool = False) -> None:
        self.drain()
        if self._fd is None:
            self.out.flush()
            return
        now = time.monotonic()
        if sync or (self.sync_every_s is not None and now - self._last_sync >= self.sync_every_s):
            self._last_sync = now
            try:
                os.fdatasync(self._fd)
            except OSError as exc:  # the rows the kernel took may not be on the disk
                if self.error is None:
                    self._fail(exc)
                    self._publish()


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
    """Drain until `stop` or the end of the commands; 1 if writing failed, else 0."""
    try:
        out = open(csv_path, "a")  # noqa: SIM115 - closed below
    except OSError as exc:  # published as a failed write is: the daemon reports it
        ring.failed_at, ring.error = ring.count, exc.errno or errno.EIO
        print(f"recording writer: {csv_path}: {exc.strerror or exc}", file=sys.stderr)
        return 1
    with out:
        drainer = Drainer(ring, out, fingers, sync_every_s)
        replies.write("ready\n")
        replies.flush()
        while True:
            readable, _, _ = select.select([commands_fd], [], [], FLUSH_INTERVAL_S)
            data = os.read(commands_fd, 4096) if readable else b"tick"
            commands = data.split()
            if not data or b"stop" in commands:  # no data: end of file, the daemon is gone
                drainer.flush(sync=True)
                return 0 if drainer.error is None else 1
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
    try:
        return serve(ring, args.csv, args.fingers.split(","), sys.stdin.fileno(), sys.stdout,
                     args.sync_every_s)
    finally:  # the daemon removes the name at stop; this is for a daemon that died
        args.ring.unlink(missing_ok=True)


if __name__ == "__main__":
    sys.exit(main())
