"""Fuzzed control-API requests: every bad one gets the API's error reply, one clear line,
never an internal error."""

from __future__ import annotations

import copy
import json
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from hypothesis import strategies as st

from hand_service.api import requests as api_requests
from hand_service.api.requests import Api
from hand_service.api.server import ApiServer, Deferred, encode_reply
from tests.fuzz.conftest import TRAJECTORY_TEXT, fuzz_tests
from tests.fuzz.strategies import json_values, raw_bytes
from tests.service.conftest import Rig

TRAJECTORY = "/fuzz-dir/trajectory.csv"  # replaced by the real folder when the Api is built
BASE = [
    {"cmd": "status"}, {"cmd": "params"}, {"cmd": "faults"}, {"cmd": "arm"}, {"cmd": "disarm"},
    {"cmd": "start"}, {"cmd": "hold"}, {"cmd": "resume"}, {"cmd": "estop"}, {"cmd": "reset"},
    {"cmd": "mode", "finger": "index", "mode": "position"}, {"cmd": "mode", "finger": "all", "mode": "vent"},
    {"cmd": "target", "finger": "index", "angle_deg": 45}, {"cmd": "target", "finger": "all", "force_n": 1.0},
    {"cmd": "target", "finger": "thumb", "pressure_kpa": 50.5},
    {"cmd": "load_trajectory", "path": TRAJECTORY, "loop": False}, {"cmd": "clear_trajectory"},
    {"cmd": "record_start", "path": "/fuzz-dir/rec.csv"}, {"cmd": "record_stop"},
]
KEYS = ["cmd", "id", "finger", "mode", "angle_deg", "force_n", "pressure_kpa", "path", "loop", "x"]


@st.composite
def mutated_request(draw: st.DrawFn) -> Any:
    request = copy.deepcopy(draw(st.sampled_from(BASE)))
    if draw(st.booleans()):
        request["id"] = draw(json_values())
    for _ in range(draw(st.integers(0, 3))):
        key = draw(st.sampled_from(KEYS) | st.sampled_from(sorted(request) or KEYS) | st.text(max_size=4))
        if draw(st.integers(0, 4)) == 0:
            request.pop(key, None)
        else:
            request[key] = draw(json_values() | st.sampled_from([-5, -0.0, 1e308, -1e-300, 181, 10**400]))
    return request


REQUESTS = st.one_of(mutated_request(), mutated_request(), mutated_request(), json_values(),
                     raw_bytes().map(lambda b: b.replace(b"\n", b" ")),
                     mutated_request().map(lambda r: json.dumps(r).encode("utf-8", "surrogatepass")))


class _Now:
    """Background, synchronously: the trajectory is parsed before the reply is asked for."""

    def __init__(self, fn: Any, *args: Any, name: str = "") -> None:
        self._result, self._error = None, None
        try:
            self._result = fn(*args)
        except Exception as exc:
            self._error = exc

    done = True

    def result(self) -> Any:
        if self._error is not None:
            raise self._error
        return self._result


def _no_recording(path: str, metadata: dict[str, object]) -> None:
    os.stat(os.path.dirname(path))  # the calls a real start makes on the path, without writing


@pytest.fixture(scope="module")
def api(fuzz_dir: Path) -> Iterator[tuple[Api, ApiServer]]:
    (fuzz_dir / "trajectory.csv").write_text(TRAJECTORY_TEXT)
    for request in BASE:
        if "path" in request:
            request["path"] = str(fuzz_dir / Path(request["path"]).name)
    rig = Rig()
    rig.tick()  # the handshake: DISARMED
    rig.sup.recorder.start = _no_recording  # type: ignore[method-assign]
    api = Api(rig.sup, metadata=lambda: {}, record_dir=fuzz_dir)  # the paths of BASE lie in it
    server = ApiServer(api.handle, None)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(api_requests, "Background", _Now)
        yield api, server
    server.selector.close()


def check(api: tuple[Api, ApiServer], request: Any) -> None:
    handler, server = api
    reply = server._answer(request) if isinstance(request, bytes) else handler.handle(request)
    if isinstance(reply, Deferred):
        handler.poll()
        reply = reply.reply()
    assert isinstance(reply, dict) and isinstance(reply.get("ok"), bool), reply
    if not reply["ok"]:
        error = reply["error"]
        assert isinstance(error, str) and error and "\n" not in error, repr(error)
        assert "internal error" not in error, error
    json.loads(encode_reply(reply))  # the reply can be written


test_request_fuzz, test_request_fuzz_full = fuzz_tests(REQUESTS, check, fixture="api")
