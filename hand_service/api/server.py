"""The control API's transport: JSON lines on a Unix-domain socket (mode 0600, peers
checked), and optionally TCP on 127.0.0.1 (token required). Polled without blocking in
the supervisor's slack, within a time budget, so requests run between ticks in the
loop's own thread and no client can stall the tick (docs/api.md)."""

from __future__ import annotations

import contextlib
import logging
import os
import selectors
import socket
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from hand_service.api.access import token_matches, token_path, write_token
from hand_service.api.clients import CAP_ERROR, TOKEN_ERROR, Clients
from hand_service.api.connection import Connection, Deferred
from hand_service.api.lines import MAX_LINE_BYTES, URGENT_CMDS, encode_reply, parse_line, urgent, with_id
from hand_service.api.listen import (
    LOOPBACK,
    default_socket_path,
    private_dir,
    same_file,
    tcp_listener,
    unix_listener,
)
from hand_service.api.refusal_log import RefusalLog

log = logging.getLogger(__name__)

DEFAULT_BUDGET_NS = 2_000_000  # a poll's work, when the caller gives no budget
ACCEPT_PER_POLL = 16  # new connections taken per poll at most (the rest wait in the backlog)
ACCEPT_MIN = 4  # taken per poll even when the budget is spent
URGENT_PER_POLL = 8  # urgent requests per connection per poll, before the others' turns

__all__ = ["LOOPBACK", "MAX_LINE_BYTES", "URGENT_CMDS", "ApiServer", "Deferred", "default_socket_path",
           "encode_reply"]

Handle = Callable[[Any], "dict[str, Any] | Deferred"]


class ApiServer(Clients):
    def __init__(self, handle: Handle, socket_path: Path | None, tcp_port: int | None = None,
                 token_file: Path | None = None) -> None:
        self.handle = handle
        self.socket_path = socket_path
        self.tcp_port = tcp_port
        if token_file is None and tcp_port is not None:
            token_file = token_path(socket_path or default_socket_path())
        self.token_file = token_file
        self.token: str | None = None
        self._refusals = RefusalLog(log)
        super().__init__()
        self.listeners: list[socket.socket] = []
        self._turn = 0
        self._made: list[tuple[Path, os.stat_result]] = []  # files this server created, removed by close()

    @property
    def listening(self) -> bool:
        return bool(self.listeners)

    def open(self) -> None:
        """Listen; on any failure, remove whatever this server created and raise (UserError)."""
        try:
            if self.socket_path is not None:
                sock, made = unix_listener(self.socket_path)
                self._made.append((self.socket_path, made))
                self._listen(sock, "unix")
            if self.tcp_port is not None:
                assert self.token_file is not None
                private_dir(self.token_file)
                self.token = write_token(self.token_file)
                self._made.append((self.token_file, os.stat(self.token_file)))
                sock = tcp_listener(self.tcp_port)
                self.tcp_port = sock.getsockname()[1]
                self._listen(sock, "tcp")
                log.info("control API on %s:%d (token in %s, 0600)", LOOPBACK, self.tcp_port, self.token_file)
        except BaseException:
            self.close()
            raise

    def _listen(self, sock: socket.socket, kind: str) -> None:
        sock.setblocking(False)
        self.listeners.append(sock)
        self.selector.register(sock, selectors.EVENT_READ, kind)

    # -- the poll ---------------------------------------------------------------------------
    def poll(self, budget_ns: int | None = None) -> int:
        """Without blocking: send, read, accept, then serve, within budget_ns of work (at
        least one request, and every urgent one); returns the requests served."""
        end_ns = time.monotonic_ns() + (DEFAULT_BUDGET_NS if budget_ns is None else max(0, budget_ns))
        for client in list(self.clients.values()):
            if client.waiting is not None and (reply := client.waiting.reply()) is not None:
                client.waiting = None
                self._reply(client, reply)
        ready: list[tuple[socket.socket, str]] = []
        for key, events in self.selector.select(0):
            client = key.data
            if not isinstance(client, Connection):
                ready.append((key.fileobj, client))  # type: ignore[arg-type]
                continue
            if events & selectors.EVENT_WRITE:
                self._send(client)
            if events & selectors.EVENT_READ and not client.closed:
                self._read(client)
        served = self._serve_urgent()  # before new connections can push one over the cap out
        for listener, kind in ready:
            self._accept(listener, kind, end_ns)
        served += self._serve_urgent()  # what the new ones sent with their connect
        self._expire(time.monotonic_ns())
        return served + self._serve_turns(end_ns, need=served == 0)

    def _serve_urgent(self) -> int:
        """First, on every connection: the urgent requests taken out while it waits for a
        deferred reply, an urgent request that is next in its turn, and the one request of a
        connection over the cap."""
        served = 0
        for client in list(self.clients.values()):
            for _ in range(URGENT_PER_POLL):
                if client.closed or client.closing or not self._urgent_next(client):
                    break
                self._serve_next(client)
                served += 1
                self._settle(client)
        return served

    @staticmethod
    def _urgent_next(client: Connection) -> bool:
        if client.urgent:
            return True
        if client.waiting is not None or not client.lines:
            return False
        head = client.lines[0]
        return client.over_cap or (head is not None and urgent(head) is not None)

    def _serve_turns(self, end_ns: int, need: bool) -> int:
        """The other requests, one per connection in turn (starting one further along at
        each poll), until the budget is spent."""
        order = [c for c in self.clients.values() if c.ready and not c.over_cap]
        if not order:
            return 0
        self._turn = (self._turn + 1) % len(order)
        order = order[self._turn:] + order[:self._turn]
        served = 0
        while order:
            later = []
            for client in order:
                if (served or not need) and time.monotonic_ns() >= end_ns:
                    return served
                self._serve_next(client)
                served += 1
                self._settle(client)
                if client.ready:
                    later.append(client)
            order = later
        return served

    def _serve_next(self, client: Connection) -> None:
        """The client's next request, in its turn (an urgent one taken out first)."""
        if client.urgent:
            self._reply(client, self._immediate(client.urgent.popleft()))
            return
        if client.refusal is not None:
            self._refuse(client, {"ok": False, "error": client.refusal})
            return
        line = client.next_line()  # None: a line over MAX_LINE_BYTES
        if client.over_cap:
            request = None if line is None else urgent(line)
            if request is None:
                self._refuse(client, {"ok": False, "error": CAP_ERROR})
            elif self._authorized(client, request):
                self._reply(client, self._immediate(request))
                client.closing = True
            return
        if not client.authenticated:
            request = None
            with contextlib.suppress(RecursionError, ValueError):
                request = None if line is None else parse_line(line)
            if self._authorized(client, request):
                self._answered(client, self._request(request))
            return
        if line is None:
            self._reply(client, {"ok": False, "error": f"request longer than {MAX_LINE_BYTES} bytes"})
            return
        self._answered(client, self._answer(line))

    def _answered(self, client: Connection, answer: dict[str, Any] | Deferred) -> None:
        if isinstance(answer, Deferred):
            client.start_waiting(answer)
        else:
            self._reply(client, answer)

    def _authorized(self, client: Connection, request: Any) -> bool:
        """A TCP client's first request must carry the token; else one error line and closed."""
        if client.authenticated:
            return True
        if isinstance(request, dict) and token_matches(request.get("token"), self.token):
            client.authenticated = True
            if not client.over_cap:
                client.deadline_ns = None
            return True
        self._refusals.refused(client.name)
        self._refuse(client, with_id(request, {"ok": False, "error": TOKEN_ERROR}))
        return False

    def _answer(self, line: bytes) -> dict[str, Any] | Deferred:
        """The reply to one line of an authenticated client."""
        try:
            request = parse_line(line)
        except RecursionError:
            return {"ok": False, "error": "not JSON: nested too deeply"}
        except ValueError as exc:  # JSONDecodeError, UnicodeDecodeError, an over-long integer
            return {"ok": False, "error": f"not JSON: {exc}"}
        return self._request(request)

    def _request(self, request: Any) -> dict[str, Any] | Deferred:
        if isinstance(request, dict) and "token" in request:  # checked already, where it counts
            request = {k: v for k, v in request.items() if k != "token"}
        if isinstance(request, dict) and request.get("cmd") == "auth":
            return with_id(request, {"ok": True, "result": {"authenticated": True}})
        return self.handle(request)

    def _immediate(self, request: dict[str, Any]) -> dict[str, Any]:
        answer = self._request(request)
        assert not isinstance(answer, Deferred), "the URGENT_CMDS are never deferred"
        return answer

    _urgent = staticmethod(urgent)

    # -- connections ------------------------------------------------------------------------
    def _accept(self, listener: socket.socket, kind: str, end_ns: int) -> None:
        for taken in range(ACCEPT_PER_POLL):
            if taken >= ACCEPT_MIN and time.monotonic_ns() >= end_ns:
                return
            try:
                sock, address = listener.accept()
            except (BlockingIOError, InterruptedError):
                return
            except OSError as exc:  # out of file descriptors: they wait in the backlog
                log.warning("cannot accept a connection: %s", exc.strerror or exc)
                return
            self._admit(sock, address, kind)

    def close(self) -> None:
        """Close every connection and listener; remove the socket and token file this server
        made (if they are still the ones it made)."""
        for client in list(self.clients.values()):
            self._drop(client)
        for sock in self.listeners:
            with contextlib.suppress(KeyError, ValueError):
                self.selector.unregister(sock)
            sock.close()
        self.listeners = []
        for path, made in self._made:
            if same_file(path, made):
                with contextlib.suppress(OSError):
                    path.unlink()
        self._made = []
        self.selector.close()
