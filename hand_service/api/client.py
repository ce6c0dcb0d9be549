"""A small Python client for the daemon's control API (docs/api.md).

    from hand_service.api.client import HandClient
    with HandClient() as hand:                 # the default socket, or HandClient(path)
        hand.arm()                             # HandClient(tcp_port=P): the token is read for you
        hand.target("index", angle_deg=45)
        hand.start()
        print(hand.status()["fingers"]["index"]["angle_deg"])
"""

from __future__ import annotations

import json
import socket
from pathlib import Path
from typing import Any

from hand_service.api.access import read_token, token_path
from hand_service.api.listen import default_socket_path


class ApiError(Exception):
    """The daemon refused a request; the message is its reply."""


class HandClient:
    """A connection to the daemon: its Unix socket, or its TCP port (then the first request
    carries the token, read from `token_file`, by default the one beside `socket_path`)."""

    def __init__(self, socket_path: str | Path | None = None, tcp_port: int | None = None,
                 timeout_s: float = 5.0, token_file: str | Path | None = None) -> None:
        path = Path(socket_path) if socket_path else default_socket_path()
        self.address = str(path) if tcp_port is None else f"127.0.0.1:{tcp_port}"
        self._token: str | None = None
        if tcp_port is None:
            self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
            target: Any = self.address
        else:
            self._token = read_token(Path(token_file) if token_file else token_path(path))
            self.sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            target = ("127.0.0.1", tcp_port)
        self.sock.settimeout(timeout_s)
        try:
            self.sock.connect(target)
        except OSError as exc:
            self.sock.close()
            raise ConnectionError(f"cannot connect to the daemon at {self.address}: "
                                  f"{exc.strerror or exc} (is `hand-service run` running?)") from None
        self._buffer = b""
        self._next_id = 0

    def request(self, cmd: str, **params: Any) -> Any:
        """Send one request and return its result; ApiError if the daemon refuses it."""
        self._next_id += 1
        message = {"cmd": cmd, "id": self._next_id, **params}
        if self._token is not None:  # the first request on the TCP port shows the token
            message["token"], self._token = self._token, None
        self.sock.sendall(json.dumps(message).encode() + b"\n")
        reply = self._read_reply()
        if not reply.get("ok"):
            raise ApiError(reply.get("error", "the daemon refused the request"))
        return reply.get("result")

    def _read_reply(self) -> dict[str, Any]:
        while b"\n" not in self._buffer:
            data = self.sock.recv(65536)
            if not data:
                raise ConnectionError(f"the daemon at {self.address} closed the connection")
            self._buffer += data
        line, self._buffer = self._buffer.split(b"\n", 1)
        return json.loads(line)

    # one method per request
    def status(self) -> dict[str, Any]:
        return self.request("status")

    def params(self) -> dict[str, Any]:
        return self.request("params")

    def faults(self) -> dict[str, Any]:
        return self.request("faults")

    def arm(self) -> dict[str, Any]:
        return self.request("arm")

    def disarm(self) -> dict[str, Any]:
        return self.request("disarm")

    def start(self) -> dict[str, Any]:
        return self.request("start")

    def hold(self) -> dict[str, Any]:
        return self.request("hold")

    def resume(self) -> dict[str, Any]:
        return self.request("resume")

    def estop(self) -> dict[str, Any]:
        return self.request("estop")

    def reset(self) -> dict[str, Any]:
        return self.request("reset")

    def mode(self, finger: str, mode: str) -> dict[str, Any]:
        return self.request("mode", finger=finger, mode=mode)

    def target(self, finger: str, **target: float) -> dict[str, Any]:
        """One of angle_deg=, force_n=, pressure_kpa=."""
        return self.request("target", finger=finger, **target)

    def load_trajectory(self, path: str | Path, loop: bool = False) -> dict[str, Any]:
        return self.request("load_trajectory", path=str(Path(path).resolve()), loop=loop)

    def clear_trajectory(self) -> dict[str, Any]:
        return self.request("clear_trajectory")

    def record_start(self, path: str | Path) -> dict[str, Any]:
        return self.request("record_start", path=str(Path(path).resolve()))

    def record_stop(self) -> dict[str, Any]:
        return self.request("record_stop")

    def close(self) -> None:
        self.sock.close()

    def __enter__(self) -> HandClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
