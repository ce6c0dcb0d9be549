"""The view's server without a browser (make test): the token is required for the stream
and the buttons, frames carry the ring's rows as they come, the E-stop button reaches the
daemon, the server listens on loopback only, and the ring is read both ways it can be."""

from __future__ import annotations

import fcntl
import json
import math
import os
import signal
import stat
import time
from pathlib import Path

import numpy as np
import pytest

from hand_service import cli
from hand_service.service.recorder_writer import HEAD, QUANTITIES
from hand_service.view.beside import WATCH_S
from hand_service.view.frames import FrameMaker
from hand_service.view.ring_tap import RingGone, RingTap
from hand_service.view.stream import NOT_RECORDING
from rtcore.config import MODE_FORCE, MODE_POSITION
from tests.browser.viewproc import DeployedDaemon, LinkedView, ViewProcess, gone, started_daemon, wait_state
from tests.service.process import wait_for

FINGERS = ["thumb", "index", "middle", "ring", "little"]


def listening_addresses(port: int) -> set[str]:
    """The local addresses of every socket listening on `port` (IPv4 and IPv6), from /proc."""
    found = set()
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        if not os.path.exists(table):
            continue
        with open(table) as f:
            next(f)
            for line in f:
                local, _remote, state = line.split()[1:4]
                address, port_hex = local.rsplit(":", 1)
                if state == "0A" and int(port_hex, 16) == port:  # 0A: LISTEN
                    found.add(address)
    return found


def test_the_stream_needs_the_token_and_carries_the_rings_rows(tmp_path: Path) -> None:
    daemon, hand = started_daemon(tmp_path)
    view = None
    try:
        view = ViewProcess(daemon, tmp_path)
        # the link carries a one-time code, never the daemon's token: it buys one session key
        assert view.token not in view.url + view.code
        assert view.request("POST", "/api/session", "0" * 32)[0] == 401
        status, reply = view.request("POST", "/api/session", view.code)
        session = json.loads(reply)["session"]
        assert status == 200 and session != view.token
        assert view.request("POST", "/api/session", view.code)[0] == 401  # spent
        assert view.request("GET", "/api/check", session)[0] == 200
        for length in ("abc", "-5", "100000"):  # refused before anything is read
            assert view.request("POST", "/api/estop", view.token, {"Content-Length": length})[0] == 400
        # loopback only: 7F000001 is 127.0.0.1, little-endian in /proc
        assert listening_addresses(view.port) == {"0100007F"}
        status, page = view.request("GET", "/")
        assert status == 200 and b"E-STOP" in page and view.token.encode() not in page
        assert view.request("GET", "/static/uPlot.iife.min.js")[0] == 200
        assert view.request("GET", "/static/../server.py")[0] == 404
        for token in (None, "", "0" * 64, view.token[:-1]):
            assert view.request("GET", "/stream", token)[0] == 401
            assert view.request("POST", "/api/estop", token)[0] == 401
        assert view.request("GET", "/api/check", view.token, {"Host": "attacker.example:80"})[0] == 403
        assert hand.status()["state"] == "DISARMED"  # no refused request reached the daemon
        assert view.request("GET", "/api/check", view.token)[0] == 200

        hand.arm()
        hand.target("all", angle_deg=40.0)
        hand.start()
        frames = [f for f in view.frames(40) if f["signals"] and f["signals"]["t_s"]]
        assert len(frames) >= 20, frames[:3]
        t = np.concatenate([f["signals"]["t_s"] for f in frames])
        period_s = 1.0 / frames[-1]["status"]["rate_hz"]
        steps = np.diff(t) / period_s
        assert np.allclose(steps, np.round(steps), atol=0.1) and (np.round(steps) >= 1).all(), \
            "a row repeated or out of order between frames"
        # a gap is a deadline the daemon itself skipped (it resumes on the schedule after a late
        # wake-up or a slow check on a loaded machine: not always a miss), never a row the view
        # lost; the daemon's count, asked after the frames, covers every gap in them
        gaps = int(np.sum(np.round(steps) - 1))
        skipped_after = hand.status()["timing"]["skipped_deadlines"]
        assert gaps <= skipped_after, "a row missing between frames"
        assert 0 <= frames[-1]["status"]["skipped_deadlines"] <= skipped_after  # the page's figure
        last = frames[-1]
        assert last["status"]["recording"]["active"]
        assert list(last["signals"]["fingers"]) == FINGERS
        index = last["signals"]["fingers"]["index"]
        assert index["angle_ref_deg"][-1] == pytest.approx(40.0)  # position mode: its reference
        assert all(v is None for v in index["force_ref_n"])  # not force mode: no force reference
        assert index["pressure_cmd_kpa"][-1] > 0
        # the simulated hand's true angle, beside the measured one (its noise, 0.3 deg, apart)
        true, measured = np.array(index["angle_true_deg"], float), np.array(index["angle_deg"], float)
        assert np.isfinite(true).all() and np.abs(true - measured).max() < 2.0

        status, body = view.request("POST", "/api/estop", view.token)
        assert status == 200 and json.loads(body) == {"ok": True, "result": {"state": "ESTOP"}}
        after = wait_state(hand, "ESTOP")
        assert after["state"] == "ESTOP"
        assert all(f["mode"] == "vent" and f["pressure_cmd_kpa"] == 0.0 for f in after["fingers"].values())
    finally:
        if view is not None:
            view.close()
        daemon.close()
    assert view.proc.returncode == 0, view.stderr.read_text()


def test_the_view_opens_the_ring_by_the_path_in_the_status(tmp_path: Path) -> None:
    """The ring keeps its name while the daemon records (mode 0600, the status's ring_path):
    the view opens it read-only and reads every row once, the simulated hand's true angle
    among them; the name goes when the recording stops, and when the daemon exits."""
    daemon, hand = started_daemon(tmp_path)
    try:
        rec = hand.status()["recording"]
        path = Path(rec["ring_path"])
        info = os.stat(path)
        assert stat.S_IMODE(info.st_mode) == 0o600 and info.st_uid == os.geteuid()
        tap = RingTap(path)
        try:
            assert fcntl.fcntl(tap.fd, fcntl.F_GETFL) & os.O_ACCMODE == os.O_RDONLY
            time.sleep(0.3)
            rows, first = tap.read_new()
            assert rows.shape[1] == len(HEAD) + len(QUANTITIES) * len(FINGERS)
            assert rows.shape[0] >= 10 and first == tap.next_row - rows.shape[0]
            steps = np.diff(rows[:, 0]) / 0.01  # one tick, or more where a loaded machine skipped one
            assert np.allclose(steps, np.round(steps), atol=1e-4) and (np.round(steps) >= 1).all()
            true_at = len(HEAD) + QUANTITIES.index("angle_true_deg") * len(FINGERS)
            assert np.isfinite(rows[:, true_at:true_at + len(FINGERS)]).all()
            time.sleep(0.2)
            more, first_more = tap.read_new()
            assert first_more == first + rows.shape[0]  # no seam: the next row pushed
            assert more[0, 0] > rows[-1, 0]
        finally:
            tap.close()
        hand.record_stop()
        # removed once the writer has drained its last rows (nominal: a few ms; bound 5 s)
        wait_for(lambda: not path.exists(), 5.0, "the ring's name to go at stop")
        again = hand.record_start(str(tmp_path / "again.csv"))
        second = Path(hand.status()["recording"]["ring_path"])
        assert second != path and second.exists(), again
        assert daemon.terminate(20.0) == 0
        assert not second.exists()  # and when the daemon exits
    finally:
        daemon.close()
    with pytest.raises(RingGone, match="cannot open the recording ring"):
        RingTap(second)


def rows_for(n: int, modes: list[int], first_t_s: float = 0.0, rate_hz: float = 1000.0) -> np.ndarray:
    nf = len(modes)
    rows = np.zeros((n, len(HEAD) + len(QUANTITIES) * nf))
    rows[:, 0] = first_t_s + np.arange(n) / rate_hz
    rows[:, 1] = 3
    for q, name in enumerate(QUANTITIES):
        for f in range(nf):
            rows[:, len(HEAD) + q * nf + f] = modes[f] if name == "mode" else 10 * q + f
    return rows


def test_frames_thin_to_the_plot_rate_without_a_seam_and_send_no_nan() -> None:
    maker = FrameMaker(["a", "b"], 1000.0)  # 1 kHz: every 5th row, 200 rows a second
    rows = rows_for(23, [MODE_POSITION, MODE_FORCE])
    rows[4, len(HEAD) + QUANTITIES.index("pressure_meas_kpa") * 2] = math.nan
    rows[5, len(HEAD) + QUANTITIES.index("angle_deg") * 2 + 1] = math.inf
    one = maker.signals(rows[:13], 0)
    two = maker.signals(rows[13:], 13)
    t = one["t_s"] + two["t_s"]  # type: ignore[operator]
    assert t == pytest.approx([i / 1000 for i in range(0, 23, 5)])
    text = json.dumps([one, two], allow_nan=False)  # raises on a NaN or an infinity
    assert json.loads(text)[0]["fingers"]["b"]["angle_deg"][1] is None
    a, b = one["fingers"]["a"], one["fingers"]["b"]  # type: ignore[index]
    assert a["angle_ref_deg"][0] == 0 and a["force_ref_n"][0] is None  # position: the angle's reference
    assert b["angle_ref_deg"][0] is None and b["force_ref_n"][0] == 71  # force: the force's
    assert one["state"] == "RUNNING"
    with pytest.raises(ValueError, match="columns"):
        maker.signals(rows[:, :-1], 0)


def test_view_without_a_daemon_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["view", "--socket", str(tmp_path / "api.sock")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith("hand-service view: error: cannot read the daemon's token")
    (tmp_path / "api.token").write_text("ab" * 32 + "\n")
    assert cli.main(["view", "--socket", str(tmp_path / "api.sock")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith("hand-service view: error: cannot reach the daemon"), err
    assert cli.main(["view", "--port", "70000"]) == 2
    assert "--port must be 0 to 65535" in capsys.readouterr().err


@pytest.mark.browser  # with make test-browser: make test keeps the token, stream and E-stop tests
def test_without_a_recording_the_page_is_told_and_view_record_starts_one(tmp_path: Path) -> None:
    daemon, hand = started_daemon(tmp_path)
    views: list[ViewProcess] = []
    try:
        hand.record_stop()
        wait_for(lambda: not hand.status()["recording"]["closing"], 20.0, "the recording to close")
        views.append(ViewProcess(daemon, tmp_path))
        frames = views[-1].frames(5)
        assert all(f["signals"] is None and f["ring_note"] == NOT_RECORDING for f in frames[1:])
        views[-1].close()
        record = tmp_path / "view.csv"
        views.append(ViewProcess(daemon, tmp_path, "--record", str(record)))
        assert hand.status()["recording"]["path"] == str(record)
        frames = views[-1].frames(60)
        assert sum(len(f["signals"]["t_s"]) for f in frames if f["signals"]) > 20
        views[-1].close()
        assert views[-1].proc.returncode == 0, views[-1].stderr.read_text()
        assert not hand.status()["recording"]["active"]  # the view stopped what it started
        assert len(record.read_text().splitlines()) > 20
    finally:
        for view in views:
            view.close()
        daemon.close()


@pytest.mark.browser  # with make test-browser: make test keeps the token, stream and E-stop tests
def test_run_view_serves_the_page_beside_the_daemon_and_ends_with_it(tmp_path: Path) -> None:
    """`run --view`: the view is a process of its own under the normal scheduler (the daemon
    as deployed, SCHED_FIFO when permitted), prints its link with the daemon's token,
    streams the recording's rows, and ends when the daemon stops or dies."""
    daemon = DeployedDaemon(tmp_path, "--view", "--status", "off")
    views: list[int] = []
    try:
        view = LinkedView(daemon)
        views.append(view.pid)
        assert len(view.code) == 32 and view.token not in view.url  # --tcp-port 0, implied
        assert os.sched_getscheduler(view.pid) == os.SCHED_OTHER
        status, page = view.request("GET", "/")
        assert status == 200 and b"E-STOP" in page
        assert view.request("GET", "/stream")[0] == 401
        frames = [f for f in view.frames(15) if f["signals"] and f["signals"]["t_s"]]
        assert frames and frames[-1]["status"]["recording"]["active"]
        assert daemon.terminate(20.0) == 0, daemon.stderr.read_text()[-2000:]
        assert gone(view.pid)  # the daemon ended it before it exited
        assert "view: stopped after" in (daemon.proc.stdout.read() if daemon.proc.stdout else "")
    finally:
        daemon.close()
        (tmp_path / "killed").mkdir()
    killed = DeployedDaemon(tmp_path / "killed", "--view", "--status", "off")
    try:
        view = LinkedView(killed)
        views.append(view.pid)
        killed.kill()  # no SIGTERM for the view: it watches its daemon (nominal 0.5 s; bound 5 s)
        wait_for(lambda: gone(view.pid), 10 * WATCH_S, "the view to end after its daemon died")
    finally:
        killed.close()
        for pid in views:  # a view that failed to end: not left behind
            if not gone(pid):
                os.kill(pid, signal.SIGKILL)
