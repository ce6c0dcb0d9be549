"""The control API's lines: a request parsed from one (JSON, no NaN, numbers within a
double), a reply written as one (always valid JSON)."""

from __future__ import annotations

import json
import logging
import math
from typing import Any

from hand_service.jsonio import plain

log = logging.getLogger(__name__)

MAX_LINE_BYTES = 65536
# Answered at once even while the same client waits for a deferred reply (a trajectory
# that loads), and the only requests served on a connection over the cap: they make the
# hand safer, and must not wait.
URGENT_CMDS = frozenset({"estop", "hold", "disarm"})
_URGENT_WORDS = tuple(cmd.encode() for cmd in URGENT_CMDS)


def _not_json(name: str) -> Any:
    raise ValueError(f"{name} is not JSON (a missing value is null)")


def _finite(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(f"{text} is out of range for a number")
    return value


def parse_line(line: bytes) -> Any:
    """The request on one line; ValueError (with the reason) or RecursionError if it is not JSON."""
    return json.loads(line, parse_constant=_not_json, parse_float=_finite)


def urgent(line: bytes) -> dict[str, Any] | None:
    """The request, if the line is one of the URGENT_CMDS (a cheap look for the word
    first: every other line is parsed only when its turn comes)."""
    if not any(word in line for word in _URGENT_WORDS):
        return None
    try:
        request = parse_line(line)
    except (RecursionError, ValueError):
        return None  # its error reply comes in its turn
    # a cmd that is not text ({"estop": 1}, unhashable) gets its error reply in its turn
    cmd = request.get("cmd") if isinstance(request, dict) else None
    if isinstance(cmd, str) and cmd in URGENT_CMDS:
        return request
    return None


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


def with_id(request: Any, reply: dict[str, Any]) -> dict[str, Any]:
    """reply, with the request's id first if it has one."""
    if isinstance(request, dict) and "id" in request:
        return {"id": request["id"], **reply}
    return reply
