"""Recording failures speak at once: a full disk (a small tmpfs the test mounts) or a
writer that died shows in `status`, the status line and the log on the tick after it
happened, with exact counts of the rows lost; control goes on, or FAULT vents when the
profile says so. A /dev/shm without room for the ring is a one-line error before the
loop (run --record) or a refused record_start, never a SIGBUS."""

from __future__ import annotations

import copy
import logging
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from hand_service.api.client import ApiError, HandClient
from hand_service.app.daemon import Daemon, DaemonOptions
from hand_service.config.profile import Profile, load_profile
from hand_service.config.recording import RecordingSettings
from hand_service.errors import UserError
from hand_service.service.recorder import WRITER_CHECK_S
from hand_service.service.recorder_writer import FLUSH_INTERVAL_S, ring_columns
from hand_service.service.recording_ring import RING_DIR_ENV
from hand_service.transports import transport_class
from rtcore.ring import Ring
from tests.service.process import wait_for

RATE_HZ = 100.0
# nominal: the writer publishes a failed write's errno at once and the tick after reads
# it, 1 row (one tick) later; the bound is ten times that
SEEN_WITHIN_ROWS = 10
# nominal: the first row that never reaches the file waits at most one drain interval for
# the writer, then the failed write is seen the tick after; the bound is five times that
FIRST_LOST_SEEN_WITHIN_ROWS = 5 * (FLUSH_INTERVAL_S * RATE_HZ + 1)


@pytest.fixture
def tmpfs(tmp_path: Path) -> Iterator[Callable[[str, int], Path]]:
    """mount(name, size_kib): a tmpfs of that size at tmp_path/name, unmounted at the end;
    the test is skipped where mounting is not permitted (not root, a container)."""
    mounted: list[Path] = []

    def mount(name: str, size_kib: int) -> Path:
        if os.geteuid() != 0:
            pytest.skip("mounting a small tmpfs (a full disk that is true to life) needs root")
        where = tmp_path / name
        where.mkdir()
        done = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size_kib}k,mode=0700", "tmpfs",
                               str(where)], capture_output=True, text=True, timeout=30)
        if done.returncode != 0:
            pytest.skip(f"cannot mount a tmpfs here: {done.stderr.strip()}")
        mounted.append(where)
        return where

    try:
        yield mount
    finally:
        for where in reversed(mounted):
            if subprocess.run(["umount", str(where)], capture_output=True, timeout=30).returncode:
                subprocess.run(["umount", "-l", str(where)], capture_output=True, timeout=30)


class Running:
    """A daemon (the real loop, API and writer process) in a thread of the test."""

    def __init__(self, tmp_path: Path, profile: Profile, record_dir: Path,
                 record: Path | None = None) -> None:
        self.socket = tmp_path / "run" / "api.sock"
        self.daemon = Daemon(profile, transport_class("sim")(profile),
                             DaemonOptions(socket_path=self.socket, record_dir=record_dir, record=record))
        self.daemon.open()
        self.thread = threading.Thread(target=self.daemon.run, kwargs={"install_signals": False})
        self.thread.start()

    def running(self, hand: HandClient) -> None:
        """DISARMED -> ARMED -> RUNNING, every finger held at 30 deg."""
        wait_for(lambda: hand.status()["state"] == "DISARMED", 10.0, "the handshake")
        hand.arm()
        hand.target("all", angle_deg=30.0)
        hand.start()

    def stop(self) -> None:
        self.daemon.sup.request_stop("test")
        self.thread.join(10)
        assert not self.thread.is_alive()


@pytest.fixture
def start_daemon(tmp_path: Path) -> Iterator[Callable[..., Running]]:
    started: list[Running] = []

    def start(profile: Profile, record_dir: Path, record: Path | None = None) -> Running:
        started.append(Running(tmp_path, profile, record_dir, record))
        return started[-1]

    try:
        yield start
    finally:
        for running in started:
            running.stop()


def _profile(on_failure: str) -> Profile:
    profile = copy.copy(load_profile(None))
    profile.recording = RecordingSettings(on_failure)
    return profile


def _data_rows(path: Path, n_columns: int) -> int:
    """The rows of a recording (not its `#` lines or its header), each checked whole."""
    lines = [ln for ln in path.read_text().splitlines() if not ln.startswith("#")]
    header, rows = lines[0].split(","), lines[1:]
    assert len(header) == n_columns
    for row in rows:
        assert len(row.split(",")) == n_columns, f"a partial row: {row!r}"
    return len(rows)


def _failure_logged(caplog: pytest.LogCaptureFixture) -> list[logging.LogRecord]:
    return [r for r in caplog.records if r.levelno >= logging.ERROR and "failed at row" in r.getMessage()]


def _full_disk(start_daemon: Callable[..., Running], tmpfs: Callable[[str, int], Path],
               on_failure: str) -> tuple[Running, HandClient, Path, dict[str, Any]]:
    """A daemon RUNNING, recording to a 32 KiB tmpfs until it is full; the status that
    first shows the failure."""
    disk = tmpfs("disk", 32)
    running = start_daemon(_profile(on_failure), disk)
    hand = HandClient(running.socket)
    running.running(hand)
    path = disk / "run.csv"
    assert hand.record_start(path)["active"]
    status = wait_for(lambda: (s := hand.status())["recording"].get("failure") and s, 20.0,
                      "the full disk in status")
    return running, hand, path, status


def _check_counts(hand: HandClient, path: Path, running: Running) -> dict[str, Any]:
    """record_stop's counts are final and exact: rows_written is the rows in the file and
    rows_lost every other row pushed; `last` says the same once the writer is reaped."""
    stopped = hand.record_stop()
    in_file = _data_rows(path, ring_columns(len(running.daemon.sup.names)))
    assert stopped["rows_written"] == in_file > 0
    assert stopped["rows_lost"] == stopped["rows"] - in_file > 0
    last = wait_for(lambda: hand.status()["recording"]["last"], 10.0, "the writer's end")
    assert {k: last[k] for k in ("rows", "rows_written", "rows_lost")} == {
        k: stopped[k] for k in ("rows", "rows_written", "rows_lost")}
    assert last["complete"] is False and last["failure"]["reason"] == stopped["failure"]["reason"]
    return stopped


def test_a_full_disk_shows_at_once_and_control_goes_on(
        start_daemon: Callable[..., Running], tmpfs: Callable[[str, int], Path],
        caplog: pytest.LogCaptureFixture) -> None:
    running, hand, path, status = _full_disk(start_daemon, tmpfs, "warning")
    with hand:
        rec, failure = status["recording"], status["recording"]["failure"]
        assert failure["errno"] == 28 and "No space left on device (ENOSPC)" in failure["reason"]
        assert 0 <= failure["seen_at_row"] - failure["at_row"] <= SEEN_WITHIN_ROWS, failure
        # the first row that never reached the file: every row before it was written
        assert rec["rows"] - rec["rows_written"] == rec["rows_lost"] and rec["lag_rows"] == 0
        assert failure["seen_at_row"] - rec["rows_written"] <= FIRST_LOST_SEEN_WITHIN_ROWS, rec
        logged = _failure_logged(caplog)  # logged then, while the daemon runs: not at shutdown
        assert len(logged) == 1 and running.thread.is_alive()
        assert "No space left on device" in logged[0].getMessage()
        assert "FAILED (No space left on device (ENOSPC))" in running.daemon.status_text()
        # control goes on: RUNNING, tracking, and every row pushed since counts as lost
        ticks = status["timing"]["ticks"]
        later = wait_for(lambda: (s := hand.status())["timing"]["ticks"] >= ticks + 30 and s, 10.0,
                         "30 more ticks")
        assert later["state"] == "RUNNING" and later["faults"]["total"] == 0
        assert all(abs(f["angle_filt_deg"] - 30.0) < 5.0 for f in later["fingers"].values())
        assert later["recording"]["rows_written"] == rec["rows_written"]
        assert later["recording"]["rows_lost"] == later["recording"]["rows"] - rec["rows_written"]
        assert later["recording"]["rows_lost"] >= rec["rows_lost"] + 30
        _check_counts(hand, path, running)
        assert hand.status()["state"] == "RUNNING"
        assert len(_failure_logged(caplog)) == 1  # once


def test_a_full_disk_faults_and_vents_when_the_profile_says_so(
        start_daemon: Callable[..., Running], tmpfs: Callable[[str, int], Path]) -> None:
    running, hand, path, status = _full_disk(start_daemon, tmpfs, "fault")
    with hand:
        failure = status["recording"]["failure"]
        assert 0 <= failure["seen_at_row"] - failure["at_row"] <= SEEN_WITHIN_ROWS, failure
        faulted = wait_for(lambda: (s := hand.status())["state"] == "FAULT" and s, 5.0, "FAULT")
        last = faulted["faults"]["last"]
        assert last["cause"] == "recording_failed" and "No space left on device" in last["detail"]
        assert last["t_s"] == failure["seen_t_s"]  # on the tick that saw it
        vented = wait_for(lambda: (s := hand.status())["tick"] > faulted["tick"] and s, 5.0, "a tick")
        assert all(f["pressure_cmd_kpa"] == 0.0 and f["mode"] == "vent" for f in vented["fingers"].values())
        # a reset does not mend the recording: arming faults again, until it is stopped
        hand.reset()
        wait_for(lambda: hand.status()["state"] == "DISARMED", 10.0, "the handshake")
        hand.arm()
        wait_for(lambda: hand.status()["state"] == "FAULT", 5.0, "FAULT again once armed")
        assert hand.faults()["counts"] == {"recording_failed": 2}
        _check_counts(hand, path, running)
        hand.reset()
        wait_for(lambda: hand.status()["state"] == "DISARMED", 10.0, "the handshake")
        assert hand.arm() == {"state": "ARMED"}
        time.sleep(0.2)
        assert hand.status()["state"] == "ARMED"


def test_a_writer_that_dies_shows_at_once(start_daemon: Callable[..., Running], tmp_path: Path,
                                          caplog: pytest.LogCaptureFixture) -> None:
    path = tmp_path / "run.csv"
    running = start_daemon(_profile("warning"), tmp_path, record=path)
    with HandClient(running.socket) as hand:
        running.running(hand)
        pid = wait_for(lambda: (r := hand.status()["recording"])["rows_written"] > 50 and r,
                       10.0, "rows in the file")["writer_pid"]
        os.kill(pid, signal.SIGKILL)
        rec = wait_for(lambda: (r := hand.status()["recording"])["failure"] and r, 5.0,
                       "the dead writer in status")
        assert rec["failure"]["reason"] == "its writer was killed by SIGKILL" and not rec["writer_alive"]
        assert rec["rows_lost"] == rec["rows"] - rec["rows_written"]
        # the loop asks after its writer every WRITER_CHECK_S; the bound is twenty times that
        wait_for(lambda: _failure_logged(caplog), 20 * WRITER_CHECK_S, "the dead writer in the log")
        assert len(_failure_logged(caplog)) == 1 and running.thread.is_alive()
        assert hand.status()["state"] == "RUNNING"
        _check_counts(hand, path, running)


def test_the_ring_is_allocated_when_it_is_made(tmp_path: Path) -> None:
    """Every page of the ring is taken when it is made (not a sparse file that a tick's
    first write into a page must find room for)."""
    ring = Ring(tmp_path / "ring", 52, 1024)
    try:
        info = os.stat(tmp_path / "ring")
        assert info.st_blocks * 512 >= info.st_size == 8 * (8 + 52 * 1024)
    finally:
        ring.close()


def test_a_small_ring_dir_refuses_run_record_before_the_loop(
        tmp_path: Path, tmpfs: Callable[[str, int], Path]) -> None:
    shm = tmpfs("shm", 64)  # the ring of five fingers at 100 Hz takes 456 KiB
    record = tmp_path / "run.csv"
    done = subprocess.run(
        [sys.executable, "-m", "hand_service.cli", "run", "--no-realtime", "--status", "off",
         "--socket", str(tmp_path / "api.sock"), "--record", str(record), "--duration", "30"],
        capture_output=True, text=True, timeout=60, env={**os.environ, RING_DIR_ENV: str(shm)})
    assert done.returncode == 2, done.stderr  # not -SIGBUS, not a traceback
    lines = done.stderr.strip().splitlines()
    assert lines[-1] == (f"hand-service run: error: cannot allocate the recording ring (456 KiB, 10 s "
                         f"of rows) in {shm}: No space left on device; free space there or set "
                         f"{RING_DIR_ENV} to a directory with room")
    assert "Traceback" not in done.stderr and "handshake" not in done.stderr  # the loop never ran
    assert not record.exists() and not (tmp_path / "api.sock").exists()
    assert list(shm.iterdir()) == []  # no ring left behind


def test_a_small_ring_dir_refuses_record_start(
        start_daemon: Callable[..., Running], tmp_path: Path, tmpfs: Callable[[str, int], Path],
        monkeypatch: pytest.MonkeyPatch) -> None:
    shm = tmpfs("shm", 256)
    monkeypatch.setenv(RING_DIR_ENV, str(shm))
    running = start_daemon(_profile("warning"), tmp_path)
    with HandClient(running.socket) as hand:
        running.running(hand)
        with pytest.raises(ApiError, match=r"^cannot allocate the recording ring \(456 "
                                           r"KiB, 10 s of rows\) in .*: No space left on device; free"):
            hand.record_start(tmp_path / "run.csv")
        status = hand.status()
        assert status["state"] == "RUNNING" and not status["recording"]["active"]
        assert not (tmp_path / "run.csv").exists() and list(shm.iterdir()) == []


def test_the_profile_chooses_what_a_recording_failure_does(tmp_path: Path) -> None:
    source = load_profile(None).path
    good = tmp_path / "fault.yaml"
    good.write_text(source.read_text() + "\nrecording:\n  on_failure: fault\n")
    assert load_profile(good).recording.faults
    assert not load_profile(None).recording.faults  # the default: a warning
    bad = tmp_path / "bad.yaml"
    bad.write_text(source.read_text() + "\nrecording:\n  on_failure: vent\n")
    with pytest.raises(UserError, match=r"bad.yaml:\d+: recording.on_failure must be one of "
                                        r"warning, fault, not 'vent'$"):
        load_profile(bad)
