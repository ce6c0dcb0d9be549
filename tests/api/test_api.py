"""The control API over its Unix socket, against a running daemon loop (in a thread
here; the process-level behaviour is in test_service.py)."""

from __future__ import annotations

import json
import os
import socket
import stat
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from hand_service.api.client import ApiError, HandClient
from hand_service.app.daemon import Daemon, DaemonOptions
from hand_service.config.profile import load_profile
from hand_service.recording import read_recording
from hand_service.transports import transport_class
from tests.service.process import wait_for


class Running:
    def __init__(self, tmp_path: Path, tcp: bool = False) -> None:
        profile = load_profile(None)
        self.socket = tmp_path / "run" / "api.sock"
        self.daemon = Daemon(profile, transport_class("sim")(profile),
                             DaemonOptions(socket_path=self.socket, tcp_port=0 if tcp else None,
                                           record_dir=tmp_path))
        self.daemon.open()
        self.thread = threading.Thread(target=self.daemon.run, kwargs={"install_signals": False})
        self.thread.start()

    def client(self) -> HandClient:
        return HandClient(self.socket)

    def wait_state(self, client: HandClient, state: str, timeout_s: float = 5.0) -> None:
        deadline = time.monotonic() + timeout_s
        while client.status()["state"] != state:
            assert time.monotonic() < deadline, f"never reached {state}"
            time.sleep(0.02)

    def hold(self, client: HandClient) -> None:
        """DISARMED -> ARMED -> RUNNING -> HOLD, every finger pressurised to 30 deg."""
        self.wait_state(client, "DISARMED")
        client.arm()
        client.target("all", angle_deg=30.0)
        client.start()
        client.hold()

    def stop(self) -> None:
        self.daemon.sup.request_stop("test")
        self.thread.join(10)
        assert not self.thread.is_alive()


@pytest.fixture
def daemon(tmp_path: Path) -> Iterator[Running]:
    running = Running(tmp_path)
    try:
        yield running
    finally:
        running.stop()


def raw(path: Path, payload: bytes) -> dict:
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as s:
        s.settimeout(5)
        s.connect(str(path))
        s.sendall(payload)
        data = b""
        while not data.endswith(b"\n"):
            chunk = s.recv(65536)
            assert chunk, "the daemon closed the connection"
            data += chunk
    return json.loads(data.splitlines()[0])


def test_socket_is_private(daemon: Running) -> None:
    mode = os.stat(daemon.socket).st_mode
    assert stat.S_ISSOCK(mode)
    assert stat.S_IMODE(mode) == 0o600


def test_a_session(daemon: Running, tmp_path: Path) -> None:
    with daemon.client() as hand:
        daemon.wait_state(hand, "DISARMED")
        params = hand.params()
        assert params["rate_hz"] == 100.0
        assert params["fingers"]["middle"]["pressure_max_kpa"] == 150.0
        assert hand.arm() == {"state": "ARMED"}
        assert hand.target("index", angle_deg=40.0)["mode"] == "position"
        assert hand.target("thumb", pressure_kpa=50.0)["mode"] == "pressure"
        assert hand.mode("ring", "vent")["mode"] == "vent"
        assert hand.start() == {"state": "RUNNING"}
        time.sleep(1.0)
        status = hand.status()
        assert status["state"] == "RUNNING"
        assert abs(status["fingers"]["index"]["angle_filt_deg"] - 40.0) < 5.0
        assert status["fingers"]["thumb"]["pressure_cmd_kpa"] == pytest.approx(50.0)
        assert status["fingers"]["ring"]["pressure_cmd_kpa"] == 0.0
        assert status["timing"]["ticks"] > 50
        assert hand.hold() == {"state": "HOLD"}
        assert hand.resume() == {"state": "RUNNING"}
        record = tmp_path / "rec.csv"
        assert hand.record_start(record)["active"]
        time.sleep(1.3)
        stopped = hand.record_stop()  # does not wait for the writer
        assert not stopped["active"] and stopped["rows"] > 100
        last = wait_for(lambda: hand.status()["recording"]["last"], 5.0, "the writer's end")
        assert last["complete"] and last["rows_lost"] == 0
        assert last["rows_written"] == stopped["rows"]
        rec = read_recording(record, finger="index")
        assert rec.duration_s > 1.0
        assert hand.disarm() == {"state": "DISARMED"}
        assert hand.estop() == {"state": "ESTOP"}
        assert hand.reset() == {"state": "INIT"}
        daemon.wait_state(hand, "DISARMED")
        assert hand.faults()["total"] == 0


def test_trajectory_runs_to_hold(daemon: Running, tmp_path: Path) -> None:
    traj = tmp_path / "wave.csv"
    traj.write_text("t,angle_ref_deg_index,angle_ref_deg_middle\n0,0,0\n0.5,30,20\n1.0,30,20\n")
    with daemon.client() as hand:
        daemon.wait_state(hand, "DISARMED")
        loaded = hand.load_trajectory(traj)
        assert loaded["fingers"] == ["index", "middle"] and loaded["ticks"] == 101
        hand.arm()
        hand.start()
        with pytest.raises(ApiError, match="follow the trajectory playing"):
            hand.target("index", angle_deg=10.0)
        hand.target("ring", angle_deg=10.0)  # a finger the trajectory leaves alone
        daemon.wait_state(hand, "HOLD", timeout_s=5.0)
        status = hand.status()
        assert status["trajectory"]["done"]
        assert status["fingers"]["index"]["angle_ref_deg"] == pytest.approx(30.0)


@pytest.mark.parametrize(("request_", "error"), [
    (b"this is not json\n", "not JSON"),
    (b"[1, 2]\n", "a JSON object with a 'cmd'"),
    (b'{"cmd": "fly"}\n', "unknown cmd 'fly'"),
    (b'{"cmd": "arm", "now": true}\n', "arm: unknown parameter 'now'"),
    (b'{"cmd": "mode", "finger": "index"}\n', "mode: missing parameter 'mode'"),
    (b'{"cmd": "mode", "finger": "index", "mode": "fly"}\n', "mode must be one of"),
    (b'{"cmd": "mode", "finger": 3, "mode": "vent"}\n', "'finger' must be str"),
    (b'{"cmd": "target", "finger": "pinky", "angle_deg": 10}\n', "unknown finger 'pinky'"),
    (b'{"cmd": "target", "finger": "index", "angle_deg": 500}\n', "outside [0, 180]"),
    (b'{"cmd": "target", "finger": "middle", "pressure_kpa": 200}\n', "outside [0, 150] for middle"),
    (b'{"cmd": "target", "finger": "index", "force_n": -11}\n', "outside [0, 10]"),
    (b'{"cmd": "target", "finger": "index", "force_n": -5}\n', "outside [0, 10]"),  # pulls: not by default
    (b'{"cmd": "target", "finger": "index", "angle_deg": "ten"}\n', "finite number"),
    (b'{"cmd": "target", "finger": "index", "angle_deg": 1, "force_n": 1}\n', "exactly one"),
    (b'{"cmd": "target", "finger": "index"}\n', "exactly one"),
    (b'{"cmd": "start"}\n', "cannot start in DISARMED"),
    (b'{"cmd": "reset"}\n', "cannot reset in DISARMED"),
    (b'{"cmd": "load_trajectory", "path": "relative.csv"}\n', "must be absolute"),
    (b'{"cmd": "load_trajectory", "path": "/nonexistent/t.csv"}\n', "outside the data directory"),
    (b'{"cmd": "record_start", "path": "rel.csv"}\n', "must be absolute"),
    (b'{"cmd": "record_stop"}\n', "not recording"),
    (b"{" + b" " * 70000 + b"\n", "not JSON"),
    # JSON has no NaN or Infinity: refused, not echoed into a reply that cannot be written
    (b'{"cmd": "status", "id": NaN}\n', "NaN is not JSON"),
    (b'{"cmd": "status", "id": -Infinity}\n', "-Infinity is not JSON"),
    (b'{"cmd": "status", "id": 1e999}\n', "1e999 is out of range"),
    (b'{"cmd": "target", "finger": "index", "angle_deg": 1e999}\n', "out of range"),
    # huge requests within the line limit: an integer of 60000 digits, nesting 30000 deep
    (b'{"cmd": "status", "id": ' + b"9" * 60000 + b"}\n", "not JSON"),
    (b"[" * 30000 + b"]" * 30000 + b"\n", "nested too deeply"),
    (b'{"cmd": "status", "id": "\xff\xfe\xc3\x28"}\n', "not JSON"),  # not UTF-8
    (b"\x80\x81\xc3\n", "not JSON"),
])
def test_invalid_requests_get_a_clear_error(daemon: Running, request_: bytes, error: str) -> None:
    with daemon.client() as hand:
        daemon.wait_state(hand, "DISARMED")
        tick = hand.status()["tick"]
    reply = raw(daemon.socket, request_)
    assert reply["ok"] is False
    assert error in reply["error"]
    with daemon.client() as hand:  # the daemon carries on, ticking
        daemon.wait_state(hand, "DISARMED")
        wait_for(lambda: hand.status()["tick"] > tick, 5.0, "the next tick")


def test_a_handler_that_raises_is_an_error_reply_and_the_loop_goes_on(daemon: Running) -> None:
    def broken() -> None:
        raise ZeroDivisionError("a bug in a handler")

    daemon.daemon.api.table["params"] = ({}, broken)
    with daemon.client() as hand:
        daemon.wait_state(hand, "DISARMED")
        tick = hand.status()["tick"]
        for _ in range(3):
            with pytest.raises(ApiError, match="params: internal error: ZeroDivisionError: a bug"):
                hand.params()
        time.sleep(0.2)
        status = hand.status()
    assert status["tick"] > tick  # still ticking
    assert status["api"]["errors"] == 3


def test_a_non_finite_result_is_written_as_null(daemon: Running) -> None:
    daemon.daemon.api.table["params"] = ({}, lambda: {"x_n": float("nan"), "y_n": float("inf")})
    reply = raw(daemon.socket, b'{"cmd": "params", "id": 4}\n')
    assert reply == {"id": 4, "ok": True, "result": {"x_n": None, "y_n": None}}


def test_over_long_line_is_refused(daemon: Running) -> None:
    reply = raw(daemon.socket, b"x" * 70000)
    assert reply == {"ok": False, "error": "request longer than 65536 bytes"}


def test_bad_trajectory_error_names_line_and_column(daemon: Running, tmp_path: Path) -> None:
    traj = tmp_path / "bad.csv"
    traj.write_text("t,angle_ref_deg_index\n0,0\n1,999\n")
    with daemon.client() as hand, pytest.raises(ApiError, match=r"bad.csv:3: column 'angle_ref_deg_index'"):
        hand.load_trajectory(traj)


def test_requests_carry_their_id(daemon: Running) -> None:
    reply = raw(daemon.socket, b'{"cmd": "status", "id": "abc"}\n')
    assert reply["id"] == "abc" and reply["ok"] is True


def test_tcp_is_loopback_only(tmp_path: Path) -> None:
    running = Running(tmp_path, tcp=True)
    try:
        port = running.daemon.server.tcp_port
        assert running.daemon.server.listeners[1].getsockname()[0] == "127.0.0.1"
        with HandClient(running.socket, tcp_port=port) as hand:  # the token beside that socket
            assert hand.status()["state"] in ("INIT", "DISARMED")
    finally:
        running.stop()


def test_wrong_tokens_are_logged_once_per_interval(tmp_path: Path,
                                                   caplog: pytest.LogCaptureFixture) -> None:
    """Any local user may knock on the TCP port as fast as it likes: one WARNING line for a
    burst of wrong tokens, not one each (about 100 a second flooded the log)."""
    running = Running(tmp_path, tcp=True)
    try:
        port = running.daemon.server.tcp_port
        with caplog.at_level("WARNING", logger="hand_service.api.server"):
            for _ in range(20):
                with socket.create_connection(("127.0.0.1", port), timeout=5) as s:
                    s.sendall(b'{"cmd": "status", "token": "%s"}\n' % (b"0" * 64))
                    assert b"refused" in s.makefile("rb").readline()
    finally:
        running.stop()
    lines = [r.getMessage() for r in caplog.records if "no valid token" in r.getMessage()]
    assert len(lines) == 1, lines


def test_second_daemon_on_the_same_socket_is_refused(daemon: Running) -> None:
    from hand_service.api.server import ApiServer
    from hand_service.errors import UserError
    with pytest.raises(UserError, match="another hand-service daemon"):
        ApiServer(lambda r: {}, daemon.socket).open()


def test_a_file_at_the_socket_path_is_never_deleted(tmp_path: Path) -> None:
    from hand_service.api.server import ApiServer
    from hand_service.errors import UserError
    precious = tmp_path / "notes.txt"
    precious.write_text("a week of lab notes\n")
    with pytest.raises(UserError, match="exists and is not a socket"):
        ApiServer(lambda r: {}, precious).open()
    assert precious.read_text() == "a week of lab notes\n"
    link = tmp_path / "link.sock"
    link.symlink_to(tmp_path / "nowhere")  # a dangling symlink is not a stale socket either
    with pytest.raises(UserError, match="exists and is not a socket"):
        ApiServer(lambda r: {}, link).open()
    assert link.is_symlink()


def test_a_stale_socket_is_replaced(tmp_path: Path) -> None:
    from hand_service.api.server import ApiServer
    path = tmp_path / "api.sock"
    dead = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    dead.bind(str(path))  # a daemon that died without removing its socket
    dead.close()
    assert path.is_socket()
    server = ApiServer(lambda r: {"ok": True}, path)
    server.open()
    try:
        with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as s:
            s.connect(str(path))  # the new daemon listens there
    finally:
        server.close()


def _replies(sock: socket.socket, n: int) -> list[dict]:
    data = b""
    while data.count(b"\n") < n:
        chunk = sock.recv(65536)
        assert chunk, "the daemon closed the connection"
        data += chunk
    return [json.loads(line) for line in data.splitlines()]


def held_parse(monkeypatch: pytest.MonkeyPatch) -> threading.Event:
    """The worker's parse waits for the returned Event (set it to let the load finish)."""
    from hand_service.api import requests as control
    release = threading.Event()
    parse = control.read_trajectory

    def slow_parse(*args: object) -> object:
        assert release.wait(10)
        return parse(*args)

    monkeypatch.setattr(control, "read_trajectory", slow_parse)
    return release


def test_a_trajectory_loads_off_the_loop(daemon: Running, tmp_path: Path,
                                         monkeypatch: pytest.MonkeyPatch) -> None:
    """While a trajectory is parsed the loop ticks on and serves everyone; the loader's
    replies come in order once it is parsed, and it is applied only if the state still
    allows it."""
    release = held_parse(monkeypatch)
    traj = tmp_path / "wave.csv"
    traj.write_text("t,angle_ref_deg_index\n0,0\n0.5,30\n1.0,30\n")
    load = json.dumps({"cmd": "load_trajectory", "path": str(traj), "id": 1}).encode()
    with daemon.client() as hand, socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as loader:
        daemon.hold(hand)
        loader.settimeout(10)
        loader.connect(str(daemon.socket))
        loader.sendall(load + b'\n{"cmd": "status", "id": 2}\n')
        tick = wait_for(lambda: (s := hand.status())["trajectory_loading"] and s["tick"], 5.0, "the load")
        wait_for(lambda: hand.status()["tick"] > tick + 20, 5.0, "ticks while the trajectory loads")
        with pytest.raises(ApiError, match="is still loading"):
            hand.load_trajectory(traj)
        release.set()
        first, second = _replies(loader, 2)
        assert first["id"] == 1 and first["ok"] and first["result"]["ticks"] == 101
        assert second["id"] == 2 and second["result"]["trajectory"]["source"] == str(traj)
        release.clear()
        loader.sendall(load + b"\n")
        wait_for(lambda: hand.status()["trajectory_loading"] == str(traj), 5.0, "the load")
        hand.resume()  # RUNNING before the parse ends: the trajectory is not applied
        release.set()
        (refused,) = _replies(loader, 1)
        assert refused == {"id": 1, "ok": False,
                           "error": "load_trajectory: not in RUNNING; hold or disarm first"}


def test_safety_requests_are_answered_while_a_load_is_pending(daemon: Running, tmp_path: Path,
                                                               monkeypatch: pytest.MonkeyPatch) -> None:
    """estop sent behind a load_trajectory on the same connection is answered at once (its
    reply before the load's), while the load's parse is still held; the other requests keep
    their order behind the load's reply."""
    release = held_parse(monkeypatch)
    traj = tmp_path / "wave.csv"
    traj.write_text("t,angle_ref_deg_index\n0,0\n0.5,30\n1.0,30\n")  # 101 ticks
    requests = [{"cmd": "load_trajectory", "path": str(traj), "id": 1}, {"cmd": "status", "id": 2},
                {"cmd": "estop", "id": 3}, {"cmd": "params", "id": 4}]
    with daemon.client() as hand, socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as loader:
        daemon.hold(hand)
        loader.settimeout(10)
        loader.connect(str(daemon.socket))
        loader.sendall(b"".join(json.dumps(r).encode() + b"\n" for r in requests))
        (stopped,) = _replies(loader, 1)
        assert stopped == {"id": 3, "ok": True, "result": {"state": "ESTOP"}}
        status = hand.status()
        assert status["state"] == "ESTOP" and status["trajectory_loading"] == str(traj)
        release.set()
        loaded, status_reply, params_reply = _replies(loader, 3)
        assert [loaded["id"], status_reply["id"], params_reply["id"]] == [1, 2, 4]
        assert loaded["ok"] and loaded["result"]["ticks"] == 101  # not RUNNING: still applied
        assert status_reply["result"]["state"] == "ESTOP"


def test_a_fifo_is_refused_and_a_later_load_works(daemon: Running, tmp_path: Path) -> None:
    """A FIFO would block the worker's open() for good (and every later load would be
    refused as "still loading"): the worker opens it without blocking and refuses it."""
    fifo = tmp_path / "fifo.csv"
    os.mkfifo(fifo)
    traj = tmp_path / "wave.csv"
    traj.write_text("t,angle_ref_deg_index\n0,0\n0.5,30\n1.0,30\n")
    with daemon.client() as hand:
        with pytest.raises(ApiError, match=f"{fifo} is not a regular file"):
            hand.load_trajectory(fifo)
        with pytest.raises(ApiError, match="is not a regular file"):
            hand.load_trajectory(tmp_path)
        assert hand.status()["trajectory_loading"] is None
        assert hand.load_trajectory(traj)["ticks"] == 101


def test_an_urgent_looking_line_whose_cmd_is_not_text_waits_its_turn() -> None:
    """`{"cmd": {"estop": 1}}` while a trajectory loads: the urgent look must not raise (a
    TypeError there would end the daemon's loop); its error reply comes in its turn."""
    from hand_service.api.server import ApiServer

    assert ApiServer._urgent(b'{"cmd": {"estop": 1}}') is None
    assert ApiServer._urgent(b'{"cmd": ["estop"]}') is None
    assert ApiServer._urgent(b'{"cmd": "estop"}') == {"cmd": "estop"}
