"""Tick recording: every tick one row into a preallocated shared-memory ring (one C call),
drained into the CSV by a writer process (hand_service.service.recorder_writer), so the tick never
waits on the disk and never shares the GIL with text formatting.

The CSV is docs/formats.md's multi-finger recording: `t`, `state`, then per finger the
suffixed columns angle_ref_deg, pressure_kpa (commanded), pressure_meas_kpa, angle_deg
(calibrated, unfiltered), angle_filt_deg, velocity_deg_per_s, force_est_n (the signed
normal force estimate), force_ref_n, mode, flags and angle_true_deg (the simulated hand's
true angle; NaN from a board), then `#` provenance lines.

The ring keeps its name while the recording runs (status()["ring_path"], mode 0600), so
that the live view opens it read-only; the name goes once the stopped writer is done (it
drains the last rows first), or with the writer process as it exits (recording_ring).

The ring is allocated in full when a recording starts, so a /dev/shm too small for it is
a one-line error then (at `run --record`, before the loop; at `record_start`, a refused
request), never a SIGBUS in a tick. A recording that stops reaching its file (a failed
write, a full disk, its writer gone) is found on the tick after (check()), and from then
every row pushed and not written counts as lost (recording_failure).
"""

from __future__ import annotations

import contextlib
import fcntl
import logging
import math
import os
import subprocess
import sys
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
from hand_service.service.recording_failure import RecordingFailure, row_counts, write_error, writer_gone
from hand_service.service.recording_ring import RING_SECONDS, allocate_ring
from hand_service.service.states import State
from rtcore.ring import ERROR, Ring

log = logging.getLogger(__name__)

__all__ = ["SHUTDOWN_STATE", "Recorder"]

STOP_TIMEOUT_S = 0.5  # how long the daemon's shutdown waits for the writer
KINDS = ("process", "thread")
WRITER_CHECK_S = 0.05  # how often check() asks whether the writer still lives
FILE_MODE = 0o640  # a new recording: owner read-write, the group read (recording.file_mode)
MAY_PRESSURISE = frozenset({State.ARMED, State.RUNNING, State.HOLD})  # a failed recording faults again


@dataclass
class _Closing:
    """A recording told to stop whose writer is still draining."""

    path: Path
    ring: Ring
    rows: int  # rows pushed, all of them
    process: subprocess.Popen[bytes] | None
    thread: WriterThread | None
    file: IO[str] | None
    failure: RecordingFailure | None  # found before it stopped

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
                 sync_every_s: float | None = None, file_mode: int = FILE_MODE) -> None:
        """sync_every_s: the writer also fdatasyncs that often (default: on faults, signals
        and at the end only; recorder_writer). file_mode: the new file's permissions, whatever
        the umask (a profile's recording.file_mode)."""
        if kind not in KINDS:
            raise UserError(f"recorder must be one of {', '.join(KINDS)}, not {kind!r}")
        if sync_every_s is not None and not 0 < sync_every_s < math.inf:
            raise UserError(f"the recording's sync interval must be a positive number of seconds, "
                            f"not {sync_every_s:g}")
        self.fingers, self.kind, self.sync_every_s = fingers, kind, sync_every_s
        self.file_mode = file_mode
        self.n_cols = ring_columns(len(fingers))
        self.capacity = max(1024, int(RING_SECONDS * rate_hz))
        self._check_every = max(1, round(WRITER_CHECK_S * rate_hz))
        self._countdown = self._check_every
        self.path: Path | None = None
        self._ring: Ring | None = None
        self._watch: np.ndarray | None = None  # the ring's header while a failure is not found yet
        self.failure: RecordingFailure | None = None  # the running recording's
        self._process: subprocess.Popen[bytes] | None = None
        self._thread: WriterThread | None = None
        self._thread_file: IO[str] | None = None
        self._closing: list[_Closing] = []
        self.last: dict[str, object] | None = None  # the last finished recording's result
        self.push_tick = self._not_recording_tick
        self._tick_source: tuple[object, object, np.ndarray, object | None] | None = None
        self._c_tick: object | None = None

    def bind(self, c_inputs: object, c_outputs: object, sent_kpa: np.ndarray,
             c_tick: object | None = None, angle_true_deg: object | None = None) -> None:
        """The control step's structs and the sent commands: push_tick(t_s, state) then
        records a tick in one C call (rtcore_ring_push_tick). c_tick: an rtcore_tick struct
        that pushes its rows itself while a recording runs (rtcore_tick_sim_at).
        angle_true_deg: a `double *` to the simulated hand's true angles for push_tick's rows
        (the simulator's outputs, the sample the tick read); None: NaN (a board)."""
        self._tick_source = (c_inputs, c_outputs, sent_kpa, angle_true_deg)
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
        # the header first, then the `#` metadata: numpy.genfromtxt(names=True) takes its names
        # from the first line, a comment or not (docs/formats.md §1)
        lines = [",".join(csv_header(self.fingers))] + [f"# {k}: {v}" for k, v in metadata.items()]
        ring, ring_path = allocate_ring(self.n_cols, self.capacity)  # before the file: nothing left
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC, self.file_mode)
            with os.fdopen(fd, "w") as f:
                os.fchmod(fd, self.file_mode)  # the umask only ever takes bits away
                f.write("\n".join(lines) + "\n")
        except OSError as exc:
            ring.close()
            Path(ring_path).unlink(missing_ok=True)
            if isinstance(exc, FileExistsError):
                raise UserError(f"{path}: exists already; a recording never overwrites one") from None
            raise UserError(f"{path}: cannot write: {exc.strerror or exc}") from None
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
                self._thread_file = open(path, "a")  # noqa: SIM115 - closed when reaped
                self._thread = WriterThread(Drainer(ring, self._thread_file, self.fingers,
                                                    self.sync_every_s))
        except OSError as exc:
            ring.close()
            Path(ring_path).unlink(missing_ok=True)
            raise UserError(f"cannot start the recording writer: {exc}") from None
        self._ring, self.path = ring, path
        self._watch, self.failure, self._countdown = ring.header, None, self._check_every
        if self._tick_source is not None:
            self.push_tick = ring.tick_pusher(len(self.fingers), *self._tick_source)
        if self._c_tick is not None:
            ring.publish_to(self._c_tick, len(self.fingers))
        log.info("recording to %s (%s writer)", path, self.kind)

    def after_tick(self, t_s: float, state: State, faults: bool) -> RecordingFailure | None:
        """The supervisor, after every tick: collect a stopped writer that is done, and
        check() the running recording. A failure found now is an error in the log, or, with
        `faults` (recording.on_failure: fault), returned for the supervisor to latch FAULT;
        so is a failed recording still running in any state that may pressurise."""
        if self._closing:
            self.reap()
        failure = self.check(t_s)
        if failure is not None and not faults:
            log.error("%s; control goes on (recording.on_failure: warning)", failure.describe())
        if not faults:
            return None
        return failure or (self.failure if state in MAY_PRESSURISE else None)

    def check(self, t_s: float) -> RecordingFailure | None:
        """Every tick (the supervisor, after the tick): a failure of the running recording
        not reported before, else None. It reads one int64 of the ring's header (the
        writer's errno); every WRITER_CHECK_S it also asks whether the writer still lives."""
        header = self._watch
        if header is None:
            return None
        if header[ERROR] == 0:
            self._countdown -= 1
            if self._countdown > 0:
                return None
            self._countdown = self._check_every
            if self._writer_alive():
                return None
        self.failure, self._watch = self._failure_now(t_s), None
        return self.failure

    def _writer_alive(self) -> bool:
        if self._process is not None:
            return self._process.poll() is None
        return self._thread is not None and not self._thread.done

    def _failure_now(self, t_s: float | None) -> RecordingFailure | None:
        """The failure the ring's header or the writer shows now, else None."""
        ring, path = self._ring, self.path
        assert ring is not None and path is not None
        failure = write_error(path, ring, ring.count, t_s)
        if failure is None and not self._writer_alive():
            code = self._process.returncode if self._process is not None else None
            failure = writer_gone(path, code, ring.count, t_s)
        return failure

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
        """Rows pushed that will never reach the file: overwritten before the writer read
        them (it fell RING_SECONDS behind), and after a failure every row not written."""
        if self._ring is not None:
            return self._counts()["rows_lost"]
        return int(self.last["rows_lost"]) if self.last else 0  # type: ignore[call-overload]

    def _counts(self) -> dict[str, int]:
        ring = self._ring
        assert ring is not None
        failed = self.failure is not None or ring.error != 0 or not self._writer_alive()
        return row_counts(ring, ring.count, failed)

    @property
    def writer_pid(self) -> int | None:
        return self._process.pid if self._process else None

    def status(self) -> dict[str, object]:
        if not self.active or self._ring is None:
            return {"active": False, "path": str(self.path) if self.path else None,
                    "closing": self.closing, "last": self.last}
        counts = self._counts()
        return {"active": True, "path": str(self.path), "writer": self.kind,
                "writer_pid": self.writer_pid, "writer_alive": self._writer_alive(),
                "ring_path": str(self._ring.path), **counts,
                "failure": self.failure.as_dict() if self.failure else None}  # as check() found it

    def stop(self, wait_s: float = 0.0) -> dict[str, object]:
        """Tell the writer to drain everything and close the file; wait at most wait_s
        (default: not at all; reap() collects the result later)."""
        if not self.active or self._ring is None or self.path is None:
            return {"active": False}
        self.push_tick = self._not_recording_tick
        if self._c_tick is not None:
            Ring.unpublish(self._c_tick)
        failure = self.failure or self._failure_now(None)
        closing = _Closing(self.path, self._ring, self._ring.count, self._process, self._thread,
                           self._thread_file, failure)
        if self._process is not None:
            self._command(b"stop")
            if self._process.stdin:
                self._process.stdin.close()  # the end of file says stop too
        if self._thread is not None:
            self._thread.request_stop()
        self._ring, self._process, self._thread, self._thread_file = None, None, None, None
        self._watch, self.failure = None, None
        self._closing.append(closing)
        self.reap(wait_s)
        if closing in self._closing:  # after a failure the counts are final already
            counts = row_counts(closing.ring, closing.rows, failure is not None)
            del counts["lag_rows"]
            return {"active": False, "path": str(closing.path), **counts, "closing": True,
                    **({"failure": failure.as_dict()} if failure else {})}
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
        if finished or closing.thread is not None:
            # the ring's name goes (the view's reader keeps what it opened); a writer process
            # still at work may not have opened it yet: it removes the name as it exits
            with contextlib.suppress(OSError):
                ring.path.unlink(missing_ok=True)
        failure = closing.failure
        if failure is None and ring.error:  # a write that failed as the writer drained its last rows
            failure = write_error(closing.path, ring, ring.count, None)
        lost = ring.lost
        drained = ring.drained
        written = drained - lost
        # a writer that finished wrote all it ever will: every other row is lost
        rows_lost = closing.rows - written if finished else lost
        exited_ok = finished and (closing.process is None or closing.process.returncode == 0)
        complete = exited_ok and drained == closing.rows and rows_lost == 0 and failure is None
        closers = [c.close for c in (closing.file, ring) if c is not None]
        if closing.thread is not None and not finished:
            closing.thread.leave(*closers)  # it still reads the ring: it closes both as it ends
        else:
            for close in closers:
                close()
        self.last = {"path": str(closing.path), "rows": closing.rows, "rows_written": written,
                     "rows_lost": rows_lost, "complete": complete}
        if failure is not None:
            self.last["failure"] = failure.as_dict()
        if complete:
            log.info("recording %s closed: %d rows", closing.path, drained)
        elif failure is not None:
            log.error("recording %s closed after its failure (%s): %d of %d rows written, %d lost",
                      closing.path, failure.reason, written, closing.rows, rows_lost)
        else:
            log.warning("recording %s closed incomplete: %d of %d rows written, %d lost (the "
                        "writer fell behind)%s", closing.path, written, closing.rows, rows_lost,
                        "" if exited_ok else "; the writer did not finish cleanly")
