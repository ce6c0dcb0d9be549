"""The stream: one thread that reads the ring about 30 times a second, asks the daemon for
its status four times a second, and hands every page the same frame as one JSON text.

A page that does not keep up loses its oldest frames (its queue holds QUEUE_FRAMES), never
slows the others or this thread; the daemon never waits for any of it (ring_tap).
"""

from __future__ import annotations

import contextlib
import json
import logging
import queue
import threading
import time
from typing import Any

from hand_service.api.client import ApiError
from hand_service.view.daemon_link import STATUS_EVERY_S, DaemonLink, brief_status
from hand_service.view.frames import FrameMaker
from hand_service.view.ring_tap import RingFollower

log = logging.getLogger(__name__)

FRAME_HZ = 30.0
QUEUE_FRAMES = 30  # a second of frames per page, then its oldest are dropped
NOT_RECORDING = ("the daemon is not recording: its ring exists only while it records "
                 "(run --record FILE, ctl record-start, or view --record FILE)")


class Stream:
    """start() the thread, subscribe() a queue of JSON frames per page, stop() at the end."""

    def __init__(self, link: DaemonLink, frame_hz: float = FRAME_HZ) -> None:
        self.link = link
        self.period_s = 1.0 / frame_hz
        self.seq = 0
        self.frames_sent = 0
        self.status: dict[str, Any] | None = None
        self.ring_note: str | None = "waiting for the daemon's status"
        self._ring = RingFollower()
        self._maker: FrameMaker | None = None
        self._subscribers: list[queue.Queue[str]] = []
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="view-stream", daemon=True)

    # -- pages ----------------------------------------------------------------------------
    def subscribe(self) -> queue.Queue[str]:
        q: queue.Queue[str] = queue.Queue(maxsize=QUEUE_FRAMES)
        with self._lock:
            self._subscribers.append(q)
        return q

    def unsubscribe(self, q: queue.Queue[str]) -> None:
        with self._lock:
            if q in self._subscribers:
                self._subscribers.remove(q)

    @property
    def pages(self) -> int:
        with self._lock:
            return len(self._subscribers)

    def _publish(self, text: str) -> None:
        with self._lock:
            subscribers = list(self._subscribers)
        for q in subscribers:
            while True:
                try:
                    q.put_nowait(text)
                    break
                except queue.Full:
                    with contextlib.suppress(queue.Empty):
                        q.get_nowait()  # the page fell a second behind: drop its oldest frame
        self.frames_sent += 1

    # -- the thread -------------------------------------------------------------------------
    def start(self) -> None:
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(5.0)
        self._detach()

    @property
    def stopped(self) -> bool:
        return self._stop.is_set()

    def _run(self) -> None:
        next_status = time.monotonic()
        next_frame = time.monotonic()
        while not self._stop.is_set():
            now = time.monotonic()
            if now >= next_status:
                self._poll_status()
                next_status = now + STATUS_EVERY_S
            try:
                self._publish(self.frame())
            except Exception:  # a bug here must not end the stream silently
                log.exception("view: a frame failed")
            next_frame += self.period_s
            delay = next_frame - time.monotonic()
            if delay < 0:  # fell behind (a loaded machine): start again from now
                next_frame, delay = time.monotonic(), 0.0
            self._stop.wait(delay)

    def _poll_status(self) -> None:
        try:
            self.status = brief_status(self.link.status())
        except (ApiError, ConnectionError) as exc:
            self.status = None
            self.ring_note = f"the daemon cannot be reached: {exc}"
            self._detach()
            return
        rec, rate_hz = self.status["recording"], float(self.status["rate_hz"])
        path = rec["ring_path"] if rec["active"] else None
        if path is None:
            self._detach()
            self.ring_note = NOT_RECORDING
        elif self._ring.follow(path, rate_hz):
            self._maker = FrameMaker(self.status["fingers"], rate_hz)
            self.ring_note = None
            log.info("view: reading the recording ring %s", path)
        elif self._ring.tap is None:
            self._maker = None
            self.ring_note = self._ring.note

    def _detach(self) -> None:
        self._ring.close()
        self._maker = None

    def frame(self) -> str:
        """The next frame: the rows pushed since the last one and the latest status, as JSON."""
        self.seq += 1
        signals = None
        missed = 0
        if self._maker is not None:
            got = self._ring.read_new()
            if got is None:  # the recording stopped between two status polls
                self.ring_note = self._ring.note
                self._maker = None
            else:
                signals = self._maker.signals(*got)
                missed = self._ring.rows_missed
        frame = {"seq": self.seq, "status": self.status, "signals": signals, "ring_note": self.ring_note,
                 "rows_missed": missed}
        return json.dumps(frame, separators=(",", ":"), allow_nan=False)


__all__ = ["FRAME_HZ", "NOT_RECORDING", "Stream"]
