"""The control API's open connections: admitted (the peer checked, within the cap or over
it), read into lines, answered, paused or dropped when they do not read, closed. The
server (server.py) decides what to serve; this keeps each connection's socket in step
with the selector."""

from __future__ import annotations

import contextlib
import logging
import os
import selectors
import socket
import time
from collections import deque
from typing import Any

from hand_service.api.access import peer, uid_allowed
from hand_service.api.connection import Connection
from hand_service.api.lines import encode_reply

log = logging.getLogger(__name__)

MAX_CLIENTS = 32  # connections served in full
MAX_OVER_CAP = 32  # more, each served one estop, hold or disarm, then closed
OVER_CAP_S = 1.0  # how long one over the cap may take to send that request
FIRST_REQUEST_S = 2.0  # how long a TCP client may take to send its first request (with the token)
# A client whose unsent replies reach OUTPUT_PAUSE_BYTES (connection.py) is served nothing
# more until it reads; one that reads none of them for STALL_S is dropped, and one with
# more than MAX_OUTPUT_BYTES unsent (urgent replies go out regardless) at once.
STALL_S = 2.0
MAX_OUTPUT_BYTES = 1024 * 1024
CAP_ERROR = (f"too many connections ({MAX_CLIENTS}): a connection over the cap is served one estop, hold "
             "or disarm, then closed (docs/api.md)")
TOKEN_ERROR = ("refused: wrong or missing token (a TCP client's first request must carry the daemon's "
               "token in 'token', docs/api.md); connection closed")


class Clients:
    """The open connections of one server, and how each is read, written and closed."""

    def __init__(self) -> None:
        self.selector = selectors.DefaultSelector()
        self.clients: dict[int, Connection] = {}  # every open connection, by file descriptor
        self.over_cap: deque[Connection] = deque()  # the open ones over the cap, oldest first
        self.dropped = 0  # clients dropped for not reading their replies

    def _admit(self, sock: socket.socket, address: Any, kind: str) -> None:
        sock.setblocking(False)
        now_ns = time.monotonic_ns()
        refusal = None
        if kind == "unix":
            pid, uid = peer(sock)
            name = f"unix uid {uid} pid {pid}"
            if not uid_allowed(uid):
                log.warning("refused a connection on the control socket from uid %s (pid %s)", uid, pid)
                refusal = f"refused: uid {uid} is neither the daemon's user (uid {os.geteuid()}) nor root"
        else:
            name = f"tcp {address[0]}:{address[1]}"
        client = Connection(sock, name, authenticated=kind == "unix" and refusal is None, refusal=refusal)
        if kind != "unix":
            client.deadline_ns = now_ns + int(FIRST_REQUEST_S * 1e9)
        # a refused peer waits among those over the cap (it never takes a slot) for its
        # first request, so that its refusal is read, not lost in a reset
        if refusal is not None or len(self.clients) - len(self.over_cap) >= MAX_CLIENTS:
            client.over_cap = True
            client.deadline_ns = now_ns + int(OVER_CAP_S * 1e9)
            self.over_cap.append(client)
            if len(self.over_cap) > MAX_OVER_CAP:  # the oldest that has sent nothing makes room
                oldest = next((c for c in self.over_cap if not c.lines), self.over_cap[0])
                self._refuse(oldest, {"ok": False, "error": CAP_ERROR})
        self.clients[sock.fileno()] = client
        self._settle(client)
        self._read(client)  # what it sent with its connect: an estop is served in this poll

    def _expire(self, now_ns: int) -> None:
        for client in list(self.clients.values()):
            if client.stalled_since_ns is not None and now_ns - client.stalled_since_ns > STALL_S * 1e9:
                self._drop_stalled(client, f"it read none of its replies for {STALL_S:g} s")
                continue
            if client.deadline_ns is None or now_ns < client.deadline_ns or client.closing:
                continue
            if client.lines:
                continue  # its first request came in time and waits for its turn
            if client.over_cap:
                self._refuse(client, {"ok": False, "error": client.refusal or CAP_ERROR})
            elif not client.authenticated:
                log.warning("refused %s: no request within %g s", client.name, FIRST_REQUEST_S)
                self._refuse(client, {"ok": False, "error": TOKEN_ERROR})

    def _refuse(self, client: Connection, reply: dict[str, Any]) -> None:
        """One error line, then closed."""
        client.clear()
        self._reply(client, reply)
        client.closing = True
        self._settle(client)

    def _read(self, client: Connection) -> None:
        if not client.may_read:
            return
        try:
            data = client.sock.recv(65536)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            data = b""
        if not data:
            client.eof = True  # it sends no more: what it sent is still served
        else:
            client.take(data)
        self._settle(client)

    def _reply(self, client: Connection, reply: dict[str, Any]) -> None:
        if client.closed:
            return
        client.outbuf += encode_reply(reply)
        client.outbuf += b"\n"
        self._send(client)
        if not client.closed and len(client.outbuf) > MAX_OUTPUT_BYTES:
            self._drop_stalled(client, f"more than the bound of {MAX_OUTPUT_BYTES} bytes")

    def _drop_stalled(self, client: Connection, why: str) -> None:
        self.dropped += 1
        log.warning("dropped %s, a client that does not read its replies: %d bytes unsent, %s",
                    client.name, len(client.outbuf), why)
        self._drop(client)

    def _send(self, client: Connection) -> None:
        if client.closed:
            return
        if client.outbuf:
            try:
                sent = client.sock.send(client.outbuf)
            except (BlockingIOError, InterruptedError):
                sent = 0
            except OSError:
                self._drop(client)
                return
            client.sent(sent, time.monotonic_ns())
        self._settle(client)

    def _settle(self, client: Connection) -> None:
        """Close it if it is done; else watch for what it can do next."""
        if client.closed:
            return
        if client.eof and not client.has_work and client.waiting is None:
            client.closing = True
        if client.closing and not client.outbuf:
            self._drop(client, drain=True)
            return
        events = (selectors.EVENT_READ if client.may_read else 0) | (
            selectors.EVENT_WRITE if client.outbuf else 0)
        if events == client.events:
            return
        with contextlib.suppress(KeyError, ValueError):
            if events == 0:
                self.selector.unregister(client.sock)
            elif client.events == 0:
                self.selector.register(client.sock, events, client)
            else:
                self.selector.modify(client.sock, events, client)
        client.events = events

    def _drop(self, client: Connection, drain: bool = False) -> None:
        """Close it; `drain`: read what it sent first, so that TCP closes with a FIN, not a
        reset that would discard the reply it has not read yet."""
        if client.closed:
            return
        client.closed = True
        if client.events:
            with contextlib.suppress(KeyError, ValueError):
                self.selector.unregister(client.sock)
        self.clients.pop(client.sock.fileno(), None)
        if client.over_cap:
            with contextlib.suppress(ValueError):
                self.over_cap.remove(client)
        if drain:
            with contextlib.suppress(OSError):
                for _ in range(4):
                    if not client.sock.recv(65536):
                        break
        client.sock.close()
