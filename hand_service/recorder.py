"""Tick recording: every tick one row into a preallocated shared-memory ring (one C call),
drained into the CSV by a writer process (hand_service.recwriter), so the tick never
waits on the disk and never shares the GIL with text formatting.

The CSV is formats.md's multi-finger recording: `t`, `state`, then per finger the
suffixed columns angle_ref_deg, pressure_kpa (commanded), pressure_meas_kpa, angle_deg
(calibrated, unfiltered), angle_filt_deg, velocity_deg_per_s, force_est_n, force_ref_n,
mode and flags, after `#` provenance lines.
"""

from __future__ import annotations

import fcntl
import logging
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from hand_service.errors import UserError
from hand_service.recwriter import HEAD, QUANTITIES, Drainer, WriterThread, csv_header, ring_columns
from rtcore.ring import Ring

log = logging.getLogger(__name__)

RING_SECONDS = 10.0  # the writer may fall this far behind before rows are lost
STOP_TIMEOUT_S = 0.5
KINDS = ("process", "thread")


def ring_dir() -> str:
    shm = "/dev/shm"
    return shm if os.path.isdir(shm) and os.access(shm, os.W_OK) else tempfile.gettempdir()


class Recorder:
    """Fill `row` through the named views (`recorder.block["angle_deg"][:] = ...`,
    `recorder.head[:] = t, state`), then `push()`; start() and stop() in between."""

    def __init__(self, fingers: list[str], rate_hz: float, kind: str = "process") -> None:
        if kind not in KINDS:
            raise UserError(f"recorder must be one of {', '.join(KINDS)}, not {kind!r}")
        self.fingers, self.kind = fingers, kind
        n = len(fingers)
        self.row = np.zeros(ring_columns(n))
        self.head = self.row[: len(HEAD)]
        self.block = {q: self.row[len(HEAD) + k * n: len(HEAD) + (k + 1) * n]
                      for k, q in enumerate(QUANTITIES)}
        self.capacity = max(1024, int(RING_SECONDS * rate_hz))
        self.path: Path | None = None
        self._ring: Ring | None = None
        self._process: subprocess.Popen[bytes] | None = None
        self._thread: WriterThread | None = None
        self._thread_file = None
        self.push = self._not_recording
        self.push_tick = self._not_recording_tick
        self._tick_source: tuple[object, object, np.ndarray] | None = None
        self.rows_lost = 0

    def bind(self, c_inputs: object, c_outputs: object, sent_kpa: np.ndarray) -> None:
        """The control step's structs and the sent commands: push_tick(t_s, state) then
        records a tick in one C call (rtcore_ring_push_tick)."""
        self._tick_source = (c_inputs, c_outputs, sent_kpa)
        if self._ring is not None:
            self.push_tick = self._ring.tick_pusher(len(self.fingers), *self._tick_source)

    @staticmethod
    def _not_recording_tick(_t_s: float, _state: int) -> int:
        return 0

    @staticmethod
    def _not_recording() -> int:
        return 0

    @property
    def active(self) -> bool:
        return self._ring is not None

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
        ring = Ring(ring_path, len(self.row), self.capacity)
        try:
            if self.kind == "process":
                self._process = subprocess.Popen(
                    [sys.executable, "-m", "hand_service.recwriter", ring_path, str(path),
                     "--fingers", ",".join(self.fingers)],
                    stdin=subprocess.PIPE, stdout=subprocess.DEVNULL)
                assert self._process.stdin is not None
                fl = fcntl.fcntl(self._process.stdin.fileno(), fcntl.F_GETFL)
                fcntl.fcntl(self._process.stdin.fileno(), fcntl.F_SETFL, fl | os.O_NONBLOCK)
            else:
                os.unlink(ring_path)
                self._thread_file = open(path, "a")  # noqa: SIM115 - closed in stop()
                self._thread = WriterThread(Drainer(ring, self._thread_file, self.fingers))
        except OSError as exc:
            ring.close()
            raise UserError(f"cannot start the recording writer: {exc}") from None
        self._ring, self.path = ring, path
        self.push = ring.pusher(self.row)
        if self._tick_source is not None:
            self.push_tick = ring.tick_pusher(len(self.fingers), *self._tick_source)
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
    def writer_pid(self) -> int | None:
        return self._process.pid if self._process else None

    def status(self) -> dict[str, object]:
        if not self.active or self._ring is None:
            return {"active": False, "path": str(self.path) if self.path else None}
        pushed, drained = self._ring.count, self._ring.drained
        alive = self._process.poll() is None if self._process else True
        return {"active": True, "path": str(self.path), "writer": self.kind,
                "writer_pid": self.writer_pid, "writer_alive": alive, "rows": pushed,
                "rows_written": drained, "lag_rows": pushed - drained}

    def stop(self, timeout_s: float = STOP_TIMEOUT_S) -> dict[str, object]:
        """Drain everything, close the file, end the writer; waits at most timeout_s."""
        if not self.active:
            return {"active": False}
        status = self.status()
        self.push = self._not_recording
        self.push_tick = self._not_recording_tick
        ok = True
        if self._process is not None:
            self._command(b"stop")
            try:
                self._process.wait(timeout_s)
            except subprocess.TimeoutExpired:
                ok = False
                log.error("recording writer did not finish in %.1f s; it goes on alone", timeout_s)
            if self._process.stdin:
                self._process.stdin.close()
        if self._thread is not None:
            ok = self._thread.stop(timeout_s)
            if self._thread_file:
                self._thread_file.close()
        if self._ring is not None:
            status["rows_written"] = self._ring.drained
            self._ring.close()
        self._ring, self._process, self._thread, self._thread_file = None, None, None, None
        status["active"], status["complete"] = False, ok
        log.info("recording %s closed: %s rows", self.path, status["rows_written"])
        return status
