"""The page's HTTP server: the standard library's ThreadingHTTPServer on 127.0.0.1 only.

    GET  /                  the page (no secret in it; it asks for the token)
    GET  /static/NAME       its script, style and the vendored uPlot
    GET  /stream            Server-Sent Events, one JSON frame per event    (token)
    GET  /api/check         {"ok": true} when the token is right             (token)
    POST /api/BUTTON        a button: estop, arm, start, hold, resume, disarm, reset  (token)
    POST /api/session       the link's one-time code (as the bearer) for a session key

The token is the daemon's API token (the file beside its socket), or a session key the
page got for the printed link's one-time code, sent by the page as
`Authorization: Bearer <hex>`; a missing or wrong one is answered 401 and nothing else.
A header, not a cookie: another site's page cannot send it without a CORS preflight,
which this server never grants. A request whose Host is not this loopback address and
port is refused (403), so that a DNS name rebound to 127.0.0.1 cannot reach it either.
"""

from __future__ import annotations

import json
import logging
import queue
import secrets
import threading
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from typing import Any

from hand_service.api.access import token_matches
from hand_service.view.daemon_link import BUTTONS, DaemonLink
from hand_service.view.stream import Stream

log = logging.getLogger(__name__)

LOOPBACK = "127.0.0.1"
KEEPALIVE_S = 1.0  # a comment line this often on a quiet stream: a closed page is found soon
MAX_BODY_BYTES = 4096  # a button carries nothing: a longer (or unreadable) length is refused
STATIC = {  # name -> content type; nothing else is ever served from the package
    "view.js": "text/javascript; charset=utf-8",
    "view.css": "text/css; charset=utf-8",
    "uPlot.iife.min.js": "text/javascript; charset=utf-8",
    "uPlot.min.css": "text/css; charset=utf-8",
    "uPlot.LICENSE": "text/plain; charset=utf-8",
}
SECURITY_HEADERS = {
    "Content-Security-Policy": "default-src 'self'; style-src 'self' 'unsafe-inline'; "
                               "connect-src 'self'; img-src 'self' data:; frame-ancestors 'none'",
    "X-Content-Type-Options": "nosniff",
    "Referrer-Policy": "no-referrer",
    "Cache-Control": "no-store",
}


def static_file(name: str) -> bytes:
    return resources.files("hand_service.view").joinpath("static", name).read_bytes()


class ViewServer(ThreadingHTTPServer):
    daemon_threads = True
    allow_reuse_address = True

    def __init__(self, stream: Stream, link: DaemonLink, token: str, port: int = 0) -> None:
        self.stream, self.link, self.token = stream, link, token
        # The printed link carries a one-time code, never the daemon's token: the first page
        # that shows it gets a session key of its own, and the code is spent (a link left in
        # a browser's command line, its history or a log opens nothing afterwards).
        self.link_code: str | None = secrets.token_hex(16)
        self.sessions: set[str] = set()
        self._codes = threading.Lock()
        self.closing = threading.Event()
        super().__init__((LOOPBACK, port), _Handler)
        self.port = int(self.server_address[1])
        self.hosts = {f"{LOOPBACK}:{self.port}", f"localhost:{self.port}"}

    @property
    def url(self) -> str:
        return f"http://{LOOPBACK}:{self.port}/"

    def close(self) -> None:
        """Stop serving and end every stream (their handlers see `closing`)."""
        self.closing.set()
        self.shutdown()
        self.server_close()


class _Handler(BaseHTTPRequestHandler):
    server: ViewServer
    protocol_version = "HTTP/1.1"

    def log_message(self, format: str, *args: Any) -> None:
        log.debug("view %s: " + format, self.client_address[0], *args)

    # -- replies ----------------------------------------------------------------------------
    def _send(self, status: HTTPStatus, body: bytes, content_type: str) -> None:
        self.send_response(status)
        self.send_header("Content-Type", content_type)
        self.send_header("Content-Length", str(len(body)))
        for key, value in SECURITY_HEADERS.items():
            self.send_header(key, value)
        self.end_headers()
        if self.command != "HEAD":
            self.wfile.write(body)

    def _json(self, status: HTTPStatus, reply: dict[str, Any]) -> None:
        self._send(status, json.dumps(reply).encode() + b"\n", "application/json")

    def _refuse(self, status: HTTPStatus, error: str) -> None:
        self._json(status, {"ok": False, "error": error})

    # -- checks -----------------------------------------------------------------------------
    def _host_ok(self) -> bool:
        if self.headers.get("Host", "") in self.server.hosts:
            return True
        self._refuse(HTTPStatus.FORBIDDEN, "refused: this server answers only to "
                     f"{LOOPBACK}:{self.server.port} (the Host header names another)")
        return False

    def _bearer(self) -> str | None:
        given = self.headers.get("Authorization", "")
        return given[len("Bearer "):].strip() if given.startswith("Bearer ") else None

    def _session(self) -> None:
        """The link's one-time code for a session key (once; then the daemon's token)."""
        code = self._bearer()
        with self.server._codes:
            spent = self.server.link_code is None or not token_matches(code, self.server.link_code)
            if not spent:
                self.server.link_code = None
                key = secrets.token_hex(32)
                self.server.sessions.add(key)
        if spent:
            log.warning("view: refused a link code from %s (wrong, or used already)", self.client_address[0])
            self._refuse(HTTPStatus.UNAUTHORIZED, "refused: the link's code opens one page once and was "
                         "used already (or is wrong): give the daemon's API token on the page")
            return
        self._json(HTTPStatus.OK, {"ok": True, "session": key})

    def _token_ok(self) -> bool:
        token = self._bearer()
        sessions = self.server.sessions
        if token_matches(token, self.server.token) or any(token_matches(token, s) for s in sessions):
            return True
        log.warning("view: refused %s %s from %s: no valid token", self.command, self.path,
                    self.client_address[0])
        self._refuse(HTTPStatus.UNAUTHORIZED, "refused: wrong or missing token (the daemon's API "
                     "token, from the file beside its socket; `hand-service view` prints the link)")
        return False

    # -- routes -----------------------------------------------------------------------------
    def do_GET(self) -> None:
        if not self._host_ok():
            return
        path = self.path.split("?", 1)[0]
        if path in ("/", "/index.html"):
            self._send(HTTPStatus.OK, static_file("index.html"), "text/html; charset=utf-8")
        elif path.startswith("/static/") and path[len("/static/"):] in STATIC:
            name = path[len("/static/"):]
            self._send(HTTPStatus.OK, static_file(name), STATIC[name])
        elif path == "/stream":
            if self._token_ok():
                self._stream()
        elif path == "/api/check":
            if self._token_ok():
                self._json(HTTPStatus.OK, {"ok": True, "buttons": list(BUTTONS)})
        else:
            self._refuse(HTTPStatus.NOT_FOUND, f"no such page: {path[:100]}")

    def do_POST(self) -> None:
        if not self._host_ok():
            return
        try:
            length = int(self.headers.get("Content-Length") or 0)
        except ValueError:
            length = -1
        if not 0 <= length <= MAX_BODY_BYTES:
            self.close_connection = True
            self._refuse(HTTPStatus.BAD_REQUEST, f"refused: a Content-Length of 0 to {MAX_BODY_BYTES} "
                         "bytes is expected")
            return
        if length:
            self.rfile.read(length)  # a button carries nothing the server reads
        path = self.path.split("?", 1)[0]
        if path == "/api/session":
            self._session()
            return
        if not self._token_ok():
            return
        button = path[len("/api/"):] if path.startswith("/api/") else ""
        if button not in BUTTONS:
            self._refuse(HTTPStatus.NOT_FOUND, f"no such button: {button[:40]!r} "
                                               f"(buttons: {', '.join(BUTTONS)})")
            return
        reply = self.server.link.press(button)
        log.info("view: %s -> %s", button, reply.get("result") if reply["ok"] else reply["error"])
        self._json(HTTPStatus.OK, reply)

    def _stream(self) -> None:
        self.send_response(HTTPStatus.OK)
        self.send_header("Content-Type", "text/event-stream")
        self.send_header("Connection", "close")  # the stream ends when the connection does
        for key, value in SECURITY_HEADERS.items():
            self.send_header(key, value)
        self.end_headers()
        self.close_connection = True
        frames = self.server.stream.subscribe()
        try:
            while not self.server.closing.is_set() and not self.server.stream.stopped:
                try:
                    text = frames.get(timeout=KEEPALIVE_S)
                except queue.Empty:
                    self.wfile.write(b": keepalive\n\n")
                else:
                    self.wfile.write(b"data: " + text.encode() + b"\n\n")
                self.wfile.flush()
        except (BrokenPipeError, ConnectionResetError, TimeoutError):
            pass  # the page went away
        finally:
            self.server.stream.unsubscribe(frames)


__all__ = ["LOOPBACK", "STATIC", "ViewServer"]
