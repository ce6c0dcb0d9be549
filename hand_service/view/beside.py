"""`run --view`: the live view as a process of its own beside the daemon, never in the
tick's process. It is started once the daemon listens (its socket and token written) and
before the loop; it prints its link on the daemon's stdout, and ends when the daemon
stops (SIGTERM from the daemon), or by itself within WATCH_S if the daemon dies
without telling it (view --with-daemon PID)."""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import sys
import time
from dataclasses import dataclass
from pathlib import Path

log = logging.getLogger(__name__)

STOP_WAIT_S = 5.0  # for the view to end after SIGTERM, before SIGKILL
WATCH_S = 0.5  # how often a view started --with-daemon checks that its daemon lives


@dataclass
class ViewChild:
    pid: int

    def wait(self, timeout_s: float) -> int | None:
        """Its exit status (a negative signal number if killed), or None if it still runs."""
        end = time.monotonic() + timeout_s
        while True:
            try:
                pid, status = os.waitpid(self.pid, os.WNOHANG)
            except ChildProcessError:
                return 0  # reaped already
            if pid:
                return os.waitstatus_to_exitcode(status)
            if time.monotonic() >= end:
                return None
            time.sleep(0.02)


def start_view(socket_path: Path, port: int = 0) -> ViewChild:
    """`hand-service view` on the daemon's socket, tied to this process, under the normal
    scheduler from its first instruction (posix_spawn's scheduler: the daemon may hold
    SCHED_FIFO already); its stdout is the daemon's (the link line), its stderr too."""
    return start_beside(["hand_service.cli", "view", "--socket", str(socket_path), "--port", str(port)])


def start_beside(module_args: list[str]) -> ViewChild:
    """`python -m MODULE ARGS... --with-daemon PID` as start_view starts the view (the
    Foxglove server of run --foxglove too)."""
    argv = [sys.executable, "-m", *module_args, "--with-daemon", str(os.getpid())]
    pid = os.posix_spawn(sys.executable, argv, dict(os.environ),
                         file_actions=[(os.POSIX_SPAWN_OPEN, 0, os.devnull, os.O_RDONLY, 0)],
                         scheduler=(os.SCHED_OTHER, os.sched_param(0)))
    return ViewChild(pid)


def stop_view(view: ViewChild) -> int | None:
    """SIGTERM, wait STOP_WAIT_S, then SIGKILL; its exit status."""
    with contextlib.suppress(ProcessLookupError):
        os.kill(view.pid, signal.SIGTERM)
    code = view.wait(STOP_WAIT_S)
    if code is None:
        log.warning("view (pid %d) did not stop in %.0f s: killed", view.pid, STOP_WAIT_S)
        with contextlib.suppress(ProcessLookupError):
            os.kill(view.pid, signal.SIGKILL)
        code = view.wait(STOP_WAIT_S)
    return code


def alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def leave_realtime() -> None:
    """The view never runs under the daemon's SCHED_FIFO, which a child started after
    setup_realtime inherits: back to the normal scheduler (always permitted)."""
    with contextlib.suppress(AttributeError, OSError):
        if os.sched_getscheduler(0) != os.SCHED_OTHER:
            os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))


__all__ = ["WATCH_S", "ViewChild", "alive", "leave_realtime", "start_beside", "start_view", "stop_view"]
