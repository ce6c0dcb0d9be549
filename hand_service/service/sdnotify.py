"""systemd's notify protocol without libsystemd: datagrams to $NOTIFY_SOCKET.

READY=1 once the daemon is up, WATCHDOG=1 at half of $WATCHDOG_USEC while the loop
ticks (systemd restarts the service when they stop), STATUS= for `systemctl status`,
STOPPING=1 on the way out. Outside systemd (no NOTIFY_SOCKET) every call does nothing.
"""

from __future__ import annotations

import logging
import os
import socket

log = logging.getLogger(__name__)


class Notifier:
    def __init__(self, environ: dict[str, str] | None = None) -> None:
        env = os.environ if environ is None else environ
        address = env.get("NOTIFY_SOCKET", "")
        self.sock: socket.socket | None = None
        self.address = address
        if address:
            if address.startswith("@"):
                address = "\0" + address[1:]  # the abstract namespace
            self.address = address
            self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM | socket.SOCK_CLOEXEC)
            self.sock.setblocking(False)
        watchdog_usec = env.get("WATCHDOG_USEC", "")
        pid = env.get("WATCHDOG_PID", "")
        enabled = watchdog_usec.isdigit() and int(watchdog_usec) > 0 and (not pid or pid == str(os.getpid()))
        self.watchdog_interval_ns = int(watchdog_usec) * 1000 // 2 if enabled and self.sock else 0
        self._last_ping_ns = 0

    @property
    def enabled(self) -> bool:
        return self.sock is not None

    def send(self, message: str) -> bool:
        if self.sock is None:
            return False
        try:
            self.sock.sendto(message.encode(), self.address)
        except OSError as exc:
            log.warning("sd_notify %r: %s", message, exc)
            return False
        return True

    def ready(self, status: str = "") -> None:
        self.send("READY=1" + (f"\nSTATUS={status}" if status else ""))

    def status(self, status: str) -> None:
        self.send(f"STATUS={status}")

    def stopping(self) -> None:
        self.send("STOPPING=1")

    def watchdog(self, now_ns: int) -> None:
        """Ping when half the watchdog period has passed since the last ping."""
        if self.watchdog_interval_ns and now_ns - self._last_ping_ns >= self.watchdog_interval_ns:
            self._last_ping_ns = now_ns
            self.send("WATCHDOG=1")

    def close(self) -> None:
        if self.sock is not None:
            self.sock.close()
            self.sock = None
