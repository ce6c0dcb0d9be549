"""`run`'s status line is ended before a log line, never continued by it (issue 43, item 7)."""

from __future__ import annotations

import io
import logging
import threading
from pathlib import Path

from hand_service.app.daemon import Daemon, DaemonOptions
from hand_service.config.profile import load_profile
from hand_service.transports import transport_class


def test_a_log_line_starts_on_its_own_line(tmp_path: Path) -> None:
    terminal = io.StringIO()  # stdout and stderr on one terminal, as a user runs it
    handler = logging.StreamHandler(terminal)
    root = logging.getLogger()
    root.addHandler(handler)
    try:
        profile = load_profile()
        daemon = Daemon(profile, transport_class("sim")(profile),
                        DaemonOptions(socket_path=tmp_path / "api.sock", status_line=True), out=terminal)
        daemon.open()
        timer = threading.Timer(0.6, logging.getLogger("hand_service.test").warning, ("a log line",))
        timer.start()
        daemon.run(duration_s=1.0, install_signals=False)
        timer.join()
    finally:
        root.removeHandler(handler)
    lines = terminal.getvalue().split("\n")
    logged = [line for line in lines if "a log line" in line]
    assert logged, terminal.getvalue()
    # the status line is rewritten after a carriage return: what a terminal shows of the
    # log's line is what follows the last \r on it
    assert all(line.split("\r")[-1].startswith("a log line") for line in logged), logged
    assert terminal.getvalue().endswith("\n")
