"""The daemon as a separate process, for tests that drive it like a lab would: through its
control socket, with signals. Every DaemonProcess is ended by close() (a fixture's
finally), whatever the test did."""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from hand_service.api.client import HandClient


def wait_for(predicate: Callable[[], Any], timeout_s: float, what: str) -> Any:
    """Poll until predicate() is truthy; its value, or an AssertionError naming `what`."""
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        value = predicate()
        if value:
            return value
        time.sleep(0.05)
    raise AssertionError(f"timed out after {timeout_s:g} s waiting for {what}")


class DaemonProcess:
    """`hand-service run --no-realtime --socket <tmp>/api.sock --record <tmp>/run.csv ...`"""

    def __init__(self, tmp_path: Path, *extra: str, env: dict[str, str] | None = None) -> None:
        self.socket = tmp_path / "api.sock"
        self.record = tmp_path / "run.csv"
        self.stderr = tmp_path / "stderr.txt"
        with open(self.stderr, "w") as err:
            self.proc = subprocess.Popen(
                [sys.executable, "-m", "hand_service.cli", "run", "--no-realtime", "--socket",
                 str(self.socket), "--record", str(self.record), *extra],
                stdout=subprocess.PIPE, stderr=err, text=True, env={**os.environ, **(env or {})})

    def client(self, timeout_s: float = 30.0) -> HandClient:
        deadline = time.monotonic() + timeout_s
        while True:
            try:
                return HandClient(self.socket)
            except ConnectionError:
                assert self.proc.poll() is None, self.stderr.read_text()
                assert time.monotonic() < deadline, "the daemon never answered"
                time.sleep(0.05)

    def disarmed(self, hand: HandClient, timeout_s: float = 30.0) -> None:
        """Wait out the handshake."""
        wait_for(lambda: hand.status()["state"] == "DISARMED", timeout_s, "the handshake")

    def terminate(self, timeout_s: float = 10.0) -> int:
        """SIGTERM, then the exit status."""
        self.proc.terminate()
        return self.proc.wait(timeout_s)

    def kill(self) -> None:
        with contextlib.suppress(ProcessLookupError):
            self.proc.kill()
        self.proc.wait(10)

    def close(self) -> None:
        self.kill()
        if self.proc.stdout is not None:
            self.proc.stdout.close()
