"""Tick recording: every tick one row into a preallocated shared-memory ring (one C call),
drained into the CSV by a writer process (hand_service.service.recorder_writer), so the tick never
waits on the disk and never shares the GIL with text formatting.

The CSV is docs/formats.md's multi-finger recording: `t`, `state`, then per finger the
suffixed columns angle_ref_deg, pressure_kpa (commanded), pressure_meas_kpa, angle_deg
(calibrated, unfiltered), angle_filt_deg, velocity_deg_per_s, force_est_n (the signed
normal force estimate), force_ref_n, mode and flags, after `#` provenance lines.
"""

from __future__ import annotations

import fcntl
import logging
import math
import os
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import IO

import numpy as np

from hand_service.errors import UserError
from hand_service.service.recorder_writer import (
    SHUTDOWN_STATE,
    Drainer,
    WriterThread,
    csv_header,
    ring_columns,
)
from rtcore.ring import Ring

log = logging.getLogger(__name__)

__all__ = ["SHUTDOWN_STATE", "Recorder"]

RING_SECONDS = 10.0  # the writer may fall this far behind before rows are lost
STOP_TIMEOUT_S = 0.5  # how long the daemon's shutdown waits for the writer
KINDS = ("process", "thread")


def ring_dir() -> str:
    shm = "/dev/shm"
    return shm if os.path.isdir(shm) and os.access(shm, os.W_OK) else tempfile.gettempdir()


@dataclass
class _Closing:
    """A recording told to stop whose writer is still draining."""

    path: Path
    ring: Ring
    rows: int  # rows pushed, all of them
    process: subprocess.Popen[bytes] | None
    thread: WriterThread | None
    file: IO[str] | None

    def finished(self, wait_s: float) -> bool:
        if self.thread is not None:
            return self.thread.join(wait_s) if wait_s > 0 else self.thread.done
        assert self.process is not None
        if wait_s <= 0:
            return self.process.poll() is not None
        try:
            self.process.wait(wait_s)
        except subprocess.TimeoutExpired:
            return False
        return True


class Recorder:
    """After bind(), push_tick(t_s, state) records one tick in one C call while a
    recording runs (start() to stop()), and does nothing otherwise.

    stop() does not wait for the writer: it drains and exits on its own, and reap() (in
    the supervisor's slack) collects its result into `last`. close() is the shutdown:
    stop, then wait at most STOP_TIMEOUT_S."""

    def __init__(self, fingers: list[str], rate_hz: float, kind: str = "process",
                 sync_every_s: float | None = None) -> None:
        """sync_every_s: the writer also fdatasyncs that often (default: on faults, signals
        and at the end only; recorder_writer)."""
        if kind not in KINDS:
            raise UserError(f"recorder must be one of {', '.join(KINDS)}, not {kind!r}")
        if sync_every_s is not None and not 0 < sync_every_s < math.inf:
            raise UserError(f"the recording's sync interval must be a positive number of seconds, "
                            f"not {sync_every_s:g}")
        self.fingers, self.kind, self.sync_every_s = fingers, kind, sync_every_s
        self.n_cols = ring_columns(len(fingers))
        self.capacity = max(1024, int(RING_SECONDS * rate_hz))
        self.path: Path | None = None
        self._ring: Ring | None = None
        self._process: subprocess.Popen[bytes] | None = None
        self._thread: WriterThread | None = None
        self._thread_file: IO[str] | None = None
        self._closing: list[_Closing] = []
        self.last: dict[str, object] | None = None  # the last finished recording's result
        self.push_tick = self._not_recording_tick
        self._tick_source: tuple[object, object, np.ndarray] | None = None
        self._c_tick: object | None = None

    def bind(self, c_inputs: object, c_outputs: object, sent_kpa: np.ndarray,
             c_tick: object | None = None) -> None:
        """The control step's structs and the sent commands: push_tick(t_s, state) then
        records a tick in one C call (rtcore_ring_push_tick). c_tick: an rtcore_tick struct
        that pushes its rows itself while a recording runs (rtcore_tick_sim_at)."""
        self._tick_source = (c_inputs, c_outputs, sent_kpa)
        if self._c_tick is not None and self._c_tick is not c_tick:
            Ring.unpublish(self._c_tick)  # the struct bound before pushes no more
        self._c_tick = c_tick
        if self._ring is not None:
            self.push_tick = self._ring.tick_pusher(len(self.fingers), *self._tick_source)
            if c_tick is not None:
                self._ring.publish_to(c_tick, len(self.fingers))

    @staticmethod
    def _not_recording_tick(_t_s: float, _state: int) -> int:
        return 0

    @property
    def active(self) -> bool:
        return self._ring is not None

    @property
    def closing(self) -> bool:
        """A stopped recording's writer has not been reaped yet."""
        return bool(self._closing)

    def start(self, path: str | Path, metadata: dict[str, object]) -> None:
        if self.active:
            raise UserError(f"already recording to {self.path}; stop first")
        path = Path(path)
        lines = [f"# {k}: {v}" for k, v in metadata.items()] + [",".join(csv_header(self.fingers))]
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            with open(path, "x") as f:
                f.write("\n".join(lines) + "\n")
        except FileExistsError:
            raise UserError(f"{path}: exists already; a recording never overwrites one") from None
        except OSError as exc:
            raise UserError(f"{path}: cannot write: {exc.strerror or exc}") from None
        fd, ring_path = tempfile.mkstemp(prefix="hand-service-ring-", dir=ring_dir())
        os.close(fd)
        os.unlink(ring_path)
        ring = Ring(ring_path, self.n_cols, self.capacity)
        try:
            if self.kind == "process":
                sync = [] if self.sync_every_s is None else ["--sync-every-s", repr(self.sync_every_s)]
                self._process = subprocess.Popen(
                    [sys.executable, "-m", "hand_service.service.recorder_writer", ring_path, str(path),
                     "--fingers", ",".join(self.fingers), *sync],
                    stdin=subprocess.PIPE, stdout=subprocess.DEVNULL)
                assert self._process.stdin is not None
                fl = fcntl.fcntl(self._process.stdin.fileno(), fcntl.F_GETFL)
                fcntl.fcntl(self._process.stdin.fileno(), fcntl.F_SETFL, fl | os.O_NONBLOCK)
            else:
                os.unlink(ring_path)
                self._thread_file = open(path, "a")  # noqa: SIM115 - closed when reaped
                self._thread = WriterThread(Drainer(ring, self._thread_file, self.fingers,
                                                    self.sync_every_s))
        except OSError as exc:
            ring.close()
            raise UserError(f"cannot start the recording writer: {exc}") from None
        self._ring, self.path = ring, path
        if self._tick_source is not None:
            self.push_tick = ring.tick_pusher(len(self.fingers), *self._tick_source)
        if self._c_tick is not None:
            ring.publish_to(self._c_tick, len(self.fingers))
        log.info("recording to %s (%s writer)", path, self.kind)

    def _command(self, word: bytes) -> None:
        if self._process is None or self._process.stdin is None:
            return
        try:
            os.write(self._process.stdin.fileno(), word + b"\n")
        except BlockingIOError:
            log.warning("recording writer is not reading its commands")
        except BrokenPipeError:
            log.error("recording writer has died (status %s)", self._process.poll())

    def flush(self) -> None:
        """Drain and flush to the file now (on a fault, a signal)."""
        if self._thread is not None:
            self._thread.flush()
        self._command(b"flush")

    @property
    def rows_pushed(self) -> int:
        return self._ring.count if self._ring else 0

    @property
    def rows_lost(self) -> int:
        """Rows the writer found overwritten (it fell RING_SECONDS behind), as it published
        them in the ring's header."""
        if self._ring is not None:
            return self._ring.lost
        return int(self.last["rows_lost"]) if self.last else 0  # type: ignore[call-overload]

    @property
    def writer_pid(self) -> int | None:
        return self._process.pid if self._process else None

    def status(self) -> dict[str, object]:
        if not self.active or self._ring is None:
            return {"active": False, "path": str(self.path) if self.path else None,
                    "closing": self.closing, "last": self.last}
        lost = self._ring.lost  # before drained, which the writer publishes first (recorder_writer)
        pushed, drained = self._ring.count, self._ring.drained
        alive = self._process.poll() is None if self._process else True
        return {"active": True, "path": str(self.path), "writer": self.kind,
                "writer_pid": self.writer_pid, "writer_alive": alive, "rows": pushed,
                "rows_written": drained - lost, "rows_lost": lost, "lag_rows": pushed - drained}

    def stop(self, wait_s: float = 0.0) -> dict[str, object]:
        """Tell the writer to drain everything and close the file; wait at most wait_s
        (default: not at all; reap() collects the result later)."""
        if not self.active or self._ring is None or self.path is None:
            return {"active": False}
        self.push_tick = self._not_recording_tick
        if self._c_tick is not None:
            Ring.unpublish(self._c_tick)
        closing = _Closing(self.path, self._ring, self._ring.count, self._process, self._thread,
                           self._thread_file)
        if self._process is not None:
            self._command(b"stop")
            if self._process.stdin:
                self._process.stdin.close()  # the end of file says stop too
        if self._thread is not None:
            self._thread.request_stop()
        self._ring, self._process, self._thread, self._thread_file = None, None, None, None
        self._closing.append(closing)
        self.reap(wait_s)
        if closing in self._closing:
            return {"active": False, "path": str(closing.path), "rows": closing.rows,
                    "rows_written": closing.ring.drained - closing.ring.lost,
                    "rows_lost": closing.ring.lost, "closing": True}
        return {**(self.last or {}), "active": False, "closing": False}

    def reap(self, wait_s: float = 0.0) -> None:
        """Collect every stopped writer that has finished, waiting at most wait_s in all."""
        deadline = time.monotonic() + wait_s
        for closing in list(self._closing):
            if closing.finished(max(0.0, deadline - time.monotonic())):
                self._finish(closing, finished=True)

    def close(self, wait_s: float = STOP_TIMEOUT_S) -> None:
        """The daemon's shutdown: stop, wait at most wait_s, leave any writer still
        draining to finish alone."""
        self.stop()
        self.reap(wait_s)
        for closing in list(self._closing):
            log.error("recording writer did not finish in %.1f s; it goes on alone", wait_s)
            self._finish(closing, finished=False)

    def _finish(self, closing: _Closing, finished: bool) -> None:
        self._closing.remove(closing)
        ring = closing.ring
        drained, lost = ring.drained, ring.lost
        exited_ok = finished and (closing.process is None or closing.process.returncode == 0)
        complete = exited_ok and drained == closing.rows and lost == 0
        closers = [c.close for c in (closing.file, ring) if c is not None]
        if closing.thread is not None and not finished:
            closing.thread.leave(*closers)  # it still reads the ring: it closes both as it ends
        else:
            for close in closers:
                close()
        self.last = {"path": str(closing.path), "rows": closing.rows, "rows_written": drained - lost,
                     "rows_lost": lost, "complete": complete}
        if complete:
            log.info("recording %s closed: %d rows", closing.path, drained)
        else:
            log.warning("recording %s closed incomplete: %d of %d rows written, %d lost (the "
                        "writer fell behind)%s", closing.path, drained - lost, closing.rows, lost,
                        "" if exited_ok else "; the writer did not finish cleanly")
