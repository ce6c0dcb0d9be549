"""The viewer's connection to the daemon's control API: the status a few times a second
(state, faults, deadline misses, the recording's writer) and the page's buttons.

Everything goes through the API as any client's requests do (docs/api.md): on the TCP
port with the daemon's token, or on the Unix socket. The daemon serves them in its
slack, within its budget per tick; the signals themselves never come this way (ring_tap).
"""

from __future__ import annotations

import logging
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hand_service.api.client import ApiError, HandClient

log = logging.getLogger(__name__)

STATUS_EVERY_S = 0.25
# the page's buttons: the requests they send (E-stop first: it is the one that matters)
BUTTONS = ("estop", "arm", "start", "hold", "resume", "disarm", "reset")


@dataclass
class LinkOptions:
    socket_path: Path
    tcp_port: int | None = None  # None: the Unix socket
    token_file: Path | None = None
    timeout_s: float = 5.0


def buttons_by_state() -> dict[str, list[str]]:
    """For each state, the buttons whose request it accepts (the state machine's own table,
    service/states.py): the page enables only those."""
    from hand_service.service.states import TRANSITIONS, Event, State

    return {state.name: [b for b in BUTTONS if (state, Event(b)) in TRANSITIONS] for state in State}


BUTTONS_BY_STATE = buttons_by_state()


def brief_status(status: dict[str, Any]) -> dict[str, Any]:
    """What the page shows of a `status` reply."""
    timing, faults, rec = status.get("timing", {}), status.get("faults", {}), status.get("recording", {})
    last = faults.get("last")
    return {
        "state": status.get("state"), "t_s": status.get("t_s"), "rate_hz": status.get("rate_hz"),
        "deadline_misses": timing.get("deadline_misses", 0),
        "skipped_deadlines": timing.get("skipped_deadlines", 0),
        "tick_us_p99": timing["tick_ns_p99"] / 1e3 if "tick_ns_p99" in timing else None,
        "faults_total": faults.get("total", 0), "faults": faults.get("counts", {}),
        "last_fault": None if last is None else {k: last.get(k) for k in ("cause", "finger", "detail", "t_s")
                                                 if k in last},
        "recording": {"active": bool(rec.get("active")), "path": rec.get("path"),
                      "rows": rec.get("rows"), "ring_path": rec.get("ring_path")},
        "fingers": list(status.get("fingers", {})),
        "buttons": BUTTONS_BY_STATE,
    }


class DaemonLink:
    """One connection, shared under a lock by the status poller and the buttons; it is
    opened again after the daemon went away."""

    def __init__(self, options: LinkOptions) -> None:
        self.options = options
        self._lock = threading.Lock()
        self._client: HandClient | None = None
        self.error: str | None = None  # why the daemon cannot be reached now

    def _connected(self) -> HandClient:
        if self._client is None:
            o = self.options
            self._client = HandClient(o.socket_path, tcp_port=o.tcp_port, timeout_s=o.timeout_s,
                                      token_file=o.token_file)
        return self._client

    def request(self, cmd: str, **params: Any) -> Any:
        """The result of one request; ApiError if refused, ConnectionError if the daemon
        cannot be reached (the next request connects again)."""
        with self._lock:
            try:
                result = self._connected().request(cmd, **params)
            except ApiError:
                raise
            except (OSError, ValueError) as exc:  # ConnectionError, a timeout, a torn reply
                self._drop()
                self.error = str(exc)
                raise ConnectionError(str(exc)) from None
            self.error = None
            return result

    def status(self) -> dict[str, Any]:
        return self.request("status")

    def press(self, button: str) -> dict[str, Any]:
        """A button of the page: {"ok": true, "result": ...} or {"ok": false, "error": ...}."""
        if button not in BUTTONS:
            return {"ok": False, "error": f"unknown button {button!r} (buttons: {', '.join(BUTTONS)})"}
        try:
            if button == "estop":  # never queued behind a status poll: a connection of its own
                return {"ok": True, "result": self.request_alone(button)}
            return {"ok": True, "result": self.request(button)}
        except (ApiError, ConnectionError) as exc:
            return {"ok": False, "error": str(exc)}

    def request_alone(self, cmd: str) -> Any:
        """One request on a connection of its own, outside the lock the polls share."""
        o = self.options
        try:
            client = HandClient(o.socket_path, tcp_port=o.tcp_port, timeout_s=o.timeout_s,
                                token_file=o.token_file)
        except (OSError, ValueError) as exc:
            raise ConnectionError(str(exc)) from None
        try:
            return client.request(cmd)
        except ApiError:
            raise
        except (OSError, ValueError) as exc:
            raise ConnectionError(str(exc)) from None
        finally:
            client.close()

    def _drop(self) -> None:
        if self._client is not None:
            self._client.close()
            self._client = None

    def close(self) -> None:
        with self._lock:
            self._drop()


__all__ = ["BUTTONS", "BUTTONS_BY_STATE", "STATUS_EVERY_S", "DaemonLink", "LinkOptions", "brief_status",
           "buttons_by_state"]
