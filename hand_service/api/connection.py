"""One client connection of the control API: what it sent and we have not served yet
(whole lines, in order), what we answered and it has not read yet, and what it may do
(authenticated or not, within the connection cap or over it)."""

from __future__ import annotations

import socket
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from hand_service.api.lines import MAX_LINE_BYTES, urgent

# A client with this much of its replies unsent (beyond what the kernel holds for it) is
# served nothing more until it reads: its requests wait, then its own sends.
OUTPUT_PAUSE_BYTES = 64 * 1024


@dataclass
class Deferred:
    """A reply that comes later, for a request served off the loop: reply() is None until
    it is ready. The client's next requests wait for it (replies stay in order), except
    the URGENT_CMDS, answered at once."""

    reply: Callable[[], dict[str, Any] | None]


@dataclass(eq=False)
class Connection:
    sock: socket.socket
    name: str  # for the log: "unix uid 1000 pid 4242", "tcp 127.0.0.1:43210"
    authenticated: bool  # the Unix socket's peer is checked at accept; a TCP client shows the token
    over_cap: bool = False  # accepted over the cap: one urgent request, then closed
    refusal: str | None = None  # a peer refused at accept: its first request gets this, then closed
    deadline_ns: int | None = None  # its first request must come by then (TCP, over the cap)
    partial: bytes = b""  # the start of a line not yet whole
    # whole lines not yet served, in order; None stands for a line over MAX_LINE_BYTES
    lines: deque[bytes | None] = field(default_factory=deque)
    queued_bytes: int = 0
    urgent: deque[dict[str, Any]] = field(default_factory=deque)  # taken out of `lines` while waiting
    outbuf: bytearray = field(default_factory=bytearray)  # replies not sent yet
    stalled_since_ns: int | None = None  # replies wait unsent, and none was sent since then
    waiting: Deferred | None = None
    closing: bool = False  # close once its replies are sent; read and serve nothing more
    closed: bool = False
    eof: bool = False  # it sent all it will: serve what it sent, then close
    events: int = 0  # what the selector watches for it

    @property
    def may_read(self) -> bool:
        """Read on while what it sent and we have not served fits one line's limit: a
        client that sends faster than it is served waits in its own send (backpressure)."""
        return (not self.closing and not self.eof
                and self.queued_bytes + len(self.partial) <= MAX_LINE_BYTES)

    def take(self, data: bytes) -> None:
        """Split what was read into whole lines; while waiting for a deferred reply, an
        urgent line is taken out to be answered at once. A line that grows past
        MAX_LINE_BYTES without its end is refused in its turn (what is left of it up to its
        end comes as another line)."""
        data = self.partial + data
        *whole, self.partial = data.split(b"\n")
        for line in whole:
            if not line.strip():
                continue
            if self.waiting is not None and (request := urgent(line)) is not None:
                self.urgent.append(request)
                continue
            self.lines.append(line)
            self.queued_bytes += len(line)
        if len(self.partial) > MAX_LINE_BYTES:
            self.lines.append(None)
            self.partial = b""

    def next_line(self) -> bytes | None:
        """The next line in its turn (call only while `lines` has one); None: one too long."""
        line = self.lines.popleft()
        if line is not None:
            self.queued_bytes -= len(line)
        return line

    def start_waiting(self, deferred: Deferred) -> None:
        """Its replies now wait for `deferred`: the urgent lines already queued behind it
        are taken out, to be answered at once."""
        self.waiting = deferred
        kept: deque[bytes | None] = deque()
        for line in self.lines:
            request = None if line is None else urgent(line)
            if request is None:
                kept.append(line)
            else:
                self.urgent.append(request)
                self.queued_bytes -= len(line)  # type: ignore[arg-type]  # not None: urgent
        self.lines = kept

    @property
    def has_work(self) -> bool:
        """Something to serve now: a line in its turn (not while waiting), or an urgent request."""
        if self.closed or self.closing:
            return False
        return bool(self.urgent) or (self.waiting is None and bool(self.lines))

    @property
    def ready(self) -> bool:
        """Work to do in its turn, and it reads its replies (OUTPUT_PAUSE_BYTES)."""
        return self.has_work and len(self.outbuf) < OUTPUT_PAUSE_BYTES

    def sent(self, n_bytes: int, now_ns: int) -> None:
        """n_bytes of its replies went out (to the kernel) at now_ns."""
        del self.outbuf[:n_bytes]
        if not self.outbuf:
            self.stalled_since_ns = None
        elif n_bytes or self.stalled_since_ns is None:
            self.stalled_since_ns = now_ns

    def clear(self) -> None:
        self.lines.clear()
        self.urgent.clear()
        self.queued_bytes = 0
        self.partial = b""
