"""A daemon with its TCP port (so it writes its token) and `hand-service view` beside it,
each a process of its own in the test's own directory, both ended by close()."""

from __future__ import annotations

import contextlib
import http.client
import json
import select
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

from hand_service.api.access import read_token, token_path
from hand_service.api.client import ApiError, HandClient
from tests.service.process import DaemonProcess

CHROMIUM = "/usr/bin/chromium"  # Debian's; Playwright downloads no browser of its own
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync"]
FINGERS = ("thumb", "index", "middle", "ring", "little")


def sweep(hand_socket: Path, stop: threading.Event) -> None:
    """Targets that keep every finger moving, each its own way, until stopped or refused."""
    with HandClient(hand_socket) as hand:
        k = 0
        while not stop.wait(0.8):
            k += 1
            try:
                for i, finger in enumerate(FINGERS):
                    hand.target(finger, angle_deg=20.0 + 12 * i + (35.0 if (k + i) % 2 else 0.0))
            except ApiError:
                return  # not while ESTOP


def link_of(line: str) -> tuple[str, str]:
    """(url, one-time code) of the view's `view: open URL#code=CODE (...)` line."""
    link = next(word for word in line.split() if word.startswith("http://"))
    url, code = link.split("#code=")
    return url, code


class ViewProcess:
    """`hand-service view --socket <daemon's>`; `url` and `token` from its first line."""

    def __init__(self, daemon: DaemonProcess, tmp_path: Path, *extra: str, timeout_s: float = 30.0) -> None:
        self.stderr = tmp_path / "view-stderr.txt"
        with open(self.stderr, "w") as err:
            self.proc = subprocess.Popen(
                [sys.executable, "-m", "hand_service.cli", "view", "--socket", str(daemon.socket), *extra],
                stdout=subprocess.PIPE, stderr=err, text=True)
        assert self.proc.stdout is not None
        ready, _, _ = select.select([self.proc.stdout], [], [], timeout_s)
        line = self.proc.stdout.readline() if ready else ""
        assert line.startswith("view: open http://127.0.0.1:"), (line, self.stderr.read_text())
        self.url, self.code = link_of(line)
        self.token = read_token(token_path(daemon.socket))  # the daemon's: the link carries none
        self.port = int(self.url.rsplit(":", 1)[1].strip("/"))

    def request(self, method: str, path: str, token: str | None = None,
                headers: dict[str, str] | None = None) -> tuple[int, bytes]:
        conn = http.client.HTTPConnection("127.0.0.1", self.port, timeout=10)
        try:
            sent = dict(headers or {})
            if token is not None:
                sent["Authorization"] = f"Bearer {token}"
            conn.request(method, path, headers=sent)
            reply = conn.getresponse()
            if reply.getheader("Content-Type") == "text/event-stream":
                return reply.status, b""  # a stream never ends: its status is the answer
            return reply.status, reply.read()
        finally:
            conn.close()

    def frames(self, n: int, token: str | None = None, timeout_s: float = 20.0) -> list[dict[str, Any]]:
        """The next n frames of the stream."""
        conn = http.client.HTTPConnection("127.0.0.1", self.port, timeout=timeout_s)
        try:
            conn.request("GET", "/stream", headers={"Authorization": f"Bearer {token or self.token}"})
            reply = conn.getresponse()
            assert reply.status == 200, reply.read()
            got: list[dict[str, Any]] = []
            while len(got) < n:
                line = reply.fp.readline()
                assert line, "the stream ended"
                if line.startswith(b"data: "):
                    got.append(json.loads(line[len(b"data: "):]))
            return got
        finally:
            conn.close()

    def close(self) -> None:
        with contextlib.suppress(ProcessLookupError):
            self.proc.terminate()
        try:
            self.proc.wait(10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait(10)
        if self.proc.stdout is not None:
            self.proc.stdout.close()


class LinkedView(ViewProcess):
    """The view a `run --view` daemon started: its link read from the daemon's stdout."""

    def __init__(self, daemon: DaemonProcess, timeout_s: float = 30.0) -> None:
        assert daemon.proc.stdout is not None
        end = time.monotonic() + timeout_s
        line = ""
        while not line.startswith("view: open http://127.0.0.1:"):
            ready, _, _ = select.select([daemon.proc.stdout], [], [], max(0.0, end - time.monotonic()))
            assert ready, ("no link from the view", daemon.stderr.read_text()[-2000:])
            line = daemon.proc.stdout.readline()
            assert line, ("the daemon's stdout ended", daemon.stderr.read_text()[-2000:])
        self.url, self.code = link_of(line)
        self.token = read_token(token_path(daemon.socket))
        self.port = int(self.url.rsplit(":", 1)[1].strip("/"))
        self.pid = next(pid for pid in children(daemon.proc.pid)
                        if b"view" in Path(f"/proc/{pid}/cmdline").read_bytes().split(b"\0"))


def children(pid: int) -> list[int]:
    """The child processes of `pid` (Linux, /proc/PID/task/*/children)."""
    found: list[int] = []
    for task in Path(f"/proc/{pid}/task").iterdir():
        with contextlib.suppress(OSError):
            found += [int(c) for c in (task / "children").read_text().split()]
    return found


def gone(pid: int) -> bool:
    """No such process, or a zombie waiting for a parent that is not this test."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] == "Z"
    except OSError:
        return True


class DeployedDaemon(DaemonProcess):
    """As DaemonProcess, with SCHED_FIFO and mlockall when permitted, as deployed."""

    def __init__(self, tmp_path: Path, *extra: str) -> None:
        self.socket = tmp_path / "api.sock"
        self.record = tmp_path / "run.csv"
        self.stderr = tmp_path / "stderr.txt"
        with open(self.stderr, "w") as err:
            self.proc = subprocess.Popen(
                [sys.executable, "-m", "hand_service.cli", "run", "--socket", str(self.socket),
                 "--record", str(self.record), *extra], stdout=subprocess.PIPE, stderr=err, text=True)


def started_daemon(tmp_path: Path, *extra: str, realtime: bool = False) -> tuple[DaemonProcess, HandClient]:
    """A daemon on the simulated hand with --tcp-port 0 (its token file), recording, DISARMED;
    with `realtime`, SCHED_FIFO as deployed (when permitted)."""
    daemon = (DeployedDaemon if realtime else DaemonProcess)(tmp_path, "--tcp-port", "0", *extra)
    try:
        hand = daemon.client()
        daemon.disarmed(hand)
    except BaseException:
        daemon.close()
        raise
    return daemon, hand


def wait_state(hand: HandClient, state: str, timeout_s: float = 10.0) -> dict[str, Any]:
    end = time.monotonic() + timeout_s
    while True:
        status = hand.status()
        if status["state"] == state or time.monotonic() > end:
            return status
        time.sleep(0.05)
