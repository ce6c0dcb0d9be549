"""The control API's transport: JSON lines on a Unix-domain socket (mode 0600), and
optionally TCP on 127.0.0.1. Polled without blocking in the supervisor's slack, so
requests run between ticks in the loop's own thread (docs/api.md)."""

from __future__ import annotations

import contextlib
import json
import logging
import math
import os
import selectors
import socket
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hand_service.errors import UserError
from hand_service.jsonio import plain

log = logging.getLogger(__name__)

MAX_LINE_BYTES = 65536
MAX_CLIENTS = 16
MAX_REQUESTS_PER_POLL = 8
# Answered at once even while the same client waits for a deferred reply (a trajectory
# that loads): they make the hand safer, and must not wait seconds behind a parse.
URGENT_CMDS = frozenset({"estop", "hold", "disarm"})
_URGENT_WORDS = tuple(cmd.encode() for cmd in URGENT_CMDS)
LOOPBACK = "127.0.0.1"


def default_socket_path() -> Path:
    """$HAND_SERVICE_SOCKET, else $XDG_RUNTIME_DIR/hand-service/api.sock, else
    /tmp/hand-service-<uid>/api.sock."""
    if os.environ.get("HAND_SERVICE_SOCKET"):
        return Path(os.environ["HAND_SERVICE_SOCKET"])
    runtime = os.environ.get("XDG_RUNTIME_DIR")
    base = Path(runtime) / "hand-service" if runtime else Path(f"/tmp/hand-service-{os.getuid()}")
    return base / "api.sock"


def _not_json(name: str) -> Any:
    raise ValueError(f"{name} is not JSON (a missing value is null)")


def _finite(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(f"{text} is out of range for a number")
    return value


def encode_reply(reply: dict[str, Any]) -> bytes:
    """One reply line: always valid JSON (a non-finite number is null, numpy values are
    plain), or an error reply if the result cannot be written at all."""
    try:
        return json.dumps(plain(reply), allow_nan=False, default=str).encode()
    except (TypeError, ValueError, RecursionError) as exc:
        log.error("cannot encode a reply: %s: %s", type(exc).__name__, exc)
        error = {"ok": False, "error": f"the reply could not be encoded: {type(exc).__name__}"}
        if isinstance(reply.get("id"), (str, int)) and not isinstance(reply.get("id"), bool):
            error["id"] = reply["id"]
        return json.dumps(error).encode()


@dataclass
class Deferred:
    """A reply that comes later, for a request served off the loop: reply() is None until
    it is ready. The client's next requests wait for it (replies stay in order), except
    the URGENT_CMDS, answered at once."""

    reply: Callable[[], dict[str, Any] | None]


class _Client:
    def __init__(self, sock: socket.socket) -> None:
        self.sock = sock
        self.inbuf = b""
        self.outbuf = b""
        self.waiting: Deferred | None = None
        self.held: deque[bytes] = deque()  # whole lines read while waiting, in order, not urgent
        self.held_bytes = 0
        self.closed = False

    def next_line(self) -> bytes | None:
        """The next whole line: the held ones first, then the unread buffer."""
        if self.held:
            line = self.held.popleft()
            self.held_bytes -= len(line)
            return line
        if b"\n" not in self.inbuf:
            return None
        line, self.inbuf = self.inbuf.split(b"\n", 1)
        return line

    def hold(self, line: bytes) -> None:
        self.held.append(line)
        self.held_bytes += len(line)


class ApiServer:
    def __init__(self, handle: Callable[[Any], dict[str, Any] | Deferred], socket_path: Path | None,
                 tcp_port: int | None = None) -> None:
        self.handle = handle
        self.socket_path = socket_path
        self.tcp_port = tcp_port
        self.selector = selectors.DefaultSelector()
        self.listeners: list[socket.socket] = []
        self.clients: dict[int, _Client] = {}
        self.pending: set[_Client] = set()  # clients with whole lines not yet answered, or waiting

    def open(self) -> None:
        if self.socket_path is not None:
            self.listeners.append(self._unix(self.socket_path))
        if self.tcp_port is not None:
            sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            try:
                sock.bind((LOOPBACK, self.tcp_port))
            except (OSError, OverflowError) as exc:  # in use, or no such port (OverflowError)
                sock.close()
                raise UserError(f"cannot listen on {LOOPBACK}:{self.tcp_port}: "
                                f"{getattr(exc, 'strerror', None) or exc}") from None
            self.tcp_port = sock.getsockname()[1]
            sock.listen(MAX_CLIENTS)
            self.listeners.append(sock)
        for sock in self.listeners:
            sock.setblocking(False)
            self.selector.register(sock, selectors.EVENT_READ, None)

    def _unix(self, path: Path) -> socket.socket:
        if not path.parent.exists():
            try:
                path.parent.mkdir(mode=0o700, parents=True)
            except OSError as exc:
                raise UserError(f"{path}: cannot create its directory: {exc.strerror or exc}") from None
        if path.is_socket():
            probe = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            try:
                probe.connect(str(path))
            except ConnectionRefusedError:
                path.unlink()  # left by a daemon that died: nobody answers
            except OSError as exc:
                raise UserError(f"{path}: a socket that cannot be probed: {exc.strerror or exc}") from None
            else:
                raise UserError(f"{path}: another hand-service daemon is listening there")
            finally:
                probe.close()
        elif path.exists() or path.is_symlink():
            raise UserError(f"{path}: exists and is not a socket; the control socket is never "
                            "created over a file (choose another --socket path)")
        sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        old = os.umask(0o177)  # the socket is created 0600: only this user may connect
        try:
            sock.bind(str(path))
        except OSError as exc:
            sock.close()
            raise UserError(f"{path}: cannot create the control socket: {exc.strerror}") from None
        finally:
            os.umask(old)
        os.chmod(path, 0o600)
        sock.listen(MAX_CLIENTS)
        log.info("control API on %s (0600)", path)
        return sock

    def poll(self) -> int:
        """Accept, read and answer whatever is ready, without blocking; returns requests served."""
        served = 0
        for client in list(self.pending):
            if client.waiting is not None:
                reply = client.waiting.reply()
                if reply is not None:
                    client.waiting = None
                    self._reply(client, reply)
            served += self._lines(client)
        for key, events in self.selector.select(0):
            sock = key.fileobj
            if key.data is None:
                self._accept(sock)  # type: ignore[arg-type]
                continue
            client: _Client = key.data
            if events & selectors.EVENT_WRITE:
                self._send(client)
            if events & selectors.EVENT_READ:
                served += self._read(client)
        return served

    def _accept(self, listener: socket.socket) -> None:
        try:
            sock, _ = listener.accept()
        except (BlockingIOError, InterruptedError):
            return
        if len(self.clients) >= MAX_CLIENTS:
            sock.close()
            return
        sock.setblocking(False)
        client = _Client(sock)
        self.clients[sock.fileno()] = client
        self.selector.register(sock, selectors.EVENT_READ, client)

    def _read(self, client: _Client) -> int:
        if client.waiting is not None and len(client.inbuf) + client.held_bytes > MAX_LINE_BYTES:
            return 0  # it waits for a reply and has sent enough: read on once it is answered
        try:
            data = client.sock.recv(65536)
        except (BlockingIOError, InterruptedError):
            return 0
        except OSError:
            data = b""
        if not data:
            self._drop(client)
            return 0
        client.inbuf += data
        return self._lines(client)

    def _lines(self, client: _Client) -> int:
        """Answer up to MAX_REQUESTS_PER_POLL whole lines, in order; the rest waits for the
        next poll. While the client waits for a deferred reply, its URGENT_CMDS are answered
        at once and its other lines are held, in order, behind that reply."""
        served = 0
        while not client.closed and served < MAX_REQUESTS_PER_POLL:
            if client.waiting is None:
                line = client.next_line()
                if line is None:
                    break
                if not line.strip():
                    continue
                answer = self._answer(line)
                served += 1
                if isinstance(answer, Deferred):
                    client.waiting = answer
                else:
                    self._reply(client, answer)
                continue
            if b"\n" not in client.inbuf:
                break
            line, client.inbuf = client.inbuf.split(b"\n", 1)
            request = self._urgent(line)
            if request is None:
                if line.strip():
                    client.hold(line)
                continue
            answer = self.handle(request)
            served += 1
            assert not isinstance(answer, Deferred), "the URGENT_CMDS are never deferred"
            self._reply(client, answer)
        if client.closed:
            return served
        if client.waiting is not None or client.held or b"\n" in client.inbuf:
            self.pending.add(client)
        else:
            self.pending.discard(client)
            if len(client.inbuf) > MAX_LINE_BYTES:
                self._reply(client, {"ok": False, "error": f"request longer than {MAX_LINE_BYTES} bytes"})
                client.inbuf = b""
        return served

    @staticmethod
    def _urgent(line: bytes) -> dict[str, Any] | None:
        """The request, if the line is one of the URGENT_CMDS (a cheap look for the word
        first: every other line is parsed only when its turn comes)."""
        if not any(word in line for word in _URGENT_WORDS):
            return None
        try:
            request = json.loads(line, parse_constant=_not_json, parse_float=_finite)
        except (RecursionError, ValueError):
            return None  # its error reply comes in its turn
        # a cmd that is not text ({"estop": 1}, unhashable) gets its error reply in its turn
        cmd = request.get("cmd") if isinstance(request, dict) else None
        if isinstance(cmd, str) and cmd in URGENT_CMDS:
            return request
        return None

    def _answer(self, line: bytes) -> dict[str, Any] | Deferred:
        try:
            request = json.loads(line, parse_constant=_not_json, parse_float=_finite)
        except RecursionError:
            return {"ok": False, "error": "not JSON: nested too deeply"}
        except ValueError as exc:  # JSONDecodeError, UnicodeDecodeError, an over-long integer
            return {"ok": False, "error": f"not JSON: {exc}"}
        return self.handle(request)

    def _reply(self, client: _Client, reply: dict[str, Any]) -> None:
        client.outbuf += encode_reply(reply) + b"\n"
        self._send(client)

    def _send(self, client: _Client) -> None:
        try:
            sent = client.sock.send(client.outbuf)
        except (BlockingIOError, InterruptedError):
            sent = 0
        except OSError:
            self._drop(client)
            return
        client.outbuf = client.outbuf[sent:]
        events = selectors.EVENT_READ | (selectors.EVENT_WRITE if client.outbuf else 0)
        with contextlib.suppress(KeyError, ValueError):
            self.selector.modify(client.sock, events, client)

    def _drop(self, client: _Client) -> None:
        client.closed = True
        self.pending.discard(client)
        with contextlib.suppress(KeyError, ValueError):
            self.selector.unregister(client.sock)
        self.clients.pop(client.sock.fileno(), None)
        client.sock.close()

    def close(self) -> None:
        for client in list(self.clients.values()):
            self._drop(client)
        for sock in self.listeners:
            with contextlib.suppress(KeyError, ValueError):
                self.selector.unregister(sock)
            sock.close()
        self.listeners = []
        if self.socket_path is not None:
            with contextlib.suppress(OSError):
                self.socket_path.unlink()
        self.selector.close()


