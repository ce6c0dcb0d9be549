"""`hand-service view` wired together: the daemon's token, the link to its API, the
stream and the HTTP server, until SIGTERM, Ctrl-C or --duration."""

from __future__ import annotations

import contextlib
import logging
import signal
import threading
import time
import webbrowser
from dataclasses import dataclass
from pathlib import Path
from typing import TextIO

from hand_service.api.access import read_token, token_path
from hand_service.api.client import ApiError
from hand_service.api.listen import default_socket_path
from hand_service.errors import UserError
from hand_service.view.beside import WATCH_S, alive
from hand_service.view.daemon_link import DaemonLink, LinkOptions
from hand_service.view.server import ViewServer
from hand_service.view.stream import Stream

log = logging.getLogger(__name__)


@dataclass
class ViewOptions:
    socket_path: Path | None = None  # the daemon's; default: as `run`
    tcp_port: int | None = None  # the daemon's TCP port; None: its Unix socket
    token_file: Path | None = None  # default: beside the socket
    port: int = 0  # the page's port on 127.0.0.1 (0: a free one)
    record: Path | None = None  # start a recording here if none runs
    open_browser: bool = False
    duration_s: float | None = None
    with_daemon: int | None = None  # end when this process (the daemon of run --view) ends


def daemon_token(options: ViewOptions) -> str:
    socket_path = options.socket_path or default_socket_path()
    path = options.token_file or token_path(socket_path)
    try:
        return read_token(path)
    except ConnectionError as exc:
        raise UserError(f"{exc}; the daemon writes its token when it runs with --tcp-port") from None


def start_recording(link: DaemonLink, record: Path) -> bool:
    """Start a recording to `record` unless one runs; whether this view started it."""
    if link.status()["recording"]["active"]:
        log.info("view: the daemon records already; --record %s is not used", record)
        return False
    try:
        link.request("record_start", path=str(record.resolve()))
    except ApiError as exc:
        raise UserError(f"--record {record}: the daemon refused: {exc}") from None
    return True


def wait(done: threading.Event, options: ViewOptions) -> None:
    """Until SIGTERM, --duration, or the daemon of --with-daemon has gone."""
    if options.with_daemon is None:
        done.wait(options.duration_s)
        return
    end = None if options.duration_s is None else time.monotonic() + options.duration_s
    while alive(options.with_daemon):
        left = WATCH_S if end is None else min(WATCH_S, end - time.monotonic())
        if left <= 0 or done.wait(left):
            return
    log.info("view: the daemon (pid %d) has gone", options.with_daemon)


def serve(options: ViewOptions, out: TextIO) -> int:
    token = daemon_token(options)
    socket_path = options.socket_path or default_socket_path()
    link = DaemonLink(LinkOptions(socket_path, options.tcp_port, options.token_file))
    try:
        link.status()
    except (ConnectionError, ApiError) as exc:
        raise UserError(f"cannot reach the daemon: {exc}") from None
    recording = options.record is not None and start_recording(link, options.record)
    stream = Stream(link)
    try:
        server = ViewServer(stream, link, token, options.port)
    except OSError as exc:
        link.close()
        raise UserError(f"--port {options.port}: cannot serve on 127.0.0.1: {exc.strerror or exc}") from None
    done = threading.Event()
    old = signal.signal(signal.SIGTERM, lambda *_: done.set())
    serving = threading.Thread(target=server.serve_forever, name="view-http", daemon=True)
    try:
        stream.start()
        serving.start()
        # the link's code opens one page once; the daemon's token never leaves this process
        out.write(f"view: open {server.url}#code={server.link_code} (the code opens one page once; "
                  "after that, give the daemon's API token on the page)\n")
        out.flush()
        log.info("view on %s (loopback only)", server.url)
        if options.open_browser:
            webbrowser.open(f"{server.url}#code={server.link_code}")
        with contextlib.suppress(KeyboardInterrupt):
            wait(done, options)
    finally:
        signal.signal(signal.SIGTERM, old)
        server.close()
        stream.stop()
        if recording:
            with contextlib.suppress(ConnectionError, ApiError):
                link.request("record_stop")
        link.close()
    out.write(f"view: stopped after {stream.frames_sent} frames\n")
    return 0


__all__ = ["ViewOptions", "daemon_token", "serve"]
