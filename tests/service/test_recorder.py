"""The recorder against a writer that stalls: rows it loses are counted, reported in the
status and at the end, and the recording is not called complete; stop never waits."""

from __future__ import annotations

import os
import signal
import threading
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

import rtcore
from hand_service.config.profile import load_profile
from hand_service.errors import UserError
from hand_service.service.recorder import Recorder
from hand_service.service.recorder_writer import Drainer, ring_columns
from tests.service.process import wait_for


@pytest.fixture
def recorder() -> Iterator[Recorder]:
    profile = load_profile()
    hand = rtcore.Hand(profile.hand_config())
    rec = Recorder(profile.finger_names, 100.0)
    rec.capacity = 16  # a tiny ring
    rec.hand = hand  # type: ignore[attr-defined]  # keeps the bound structs alive
    rec.bind(hand.c_inputs, hand.c_outputs, np.zeros(len(profile.fingers)))
    try:
        yield rec
    finally:
        rec.close(wait_s=5.0)


def _stalled(rec: Recorder) -> int:
    pid = rec.writer_pid
    assert pid is not None
    os.kill(pid, signal.SIGSTOP)
    return pid


def test_rows_lost_to_a_stalled_writer_are_reported(recorder: Recorder, tmp_path: Path) -> None:
    path = tmp_path / "lossy.csv"
    recorder.start(path, {"test": "stalled writer"})
    pid = _stalled(recorder)
    try:
        for k in range(40):
            recorder.push_tick(k / 100, 3)
    finally:
        os.kill(pid, signal.SIGCONT)
    status = wait_for(lambda: (s := recorder.status())["rows_lost"] and s, 5.0, "the writer's drain")
    assert status["rows"] == 40 and status["rows_lost"] == 25 and status["rows_written"] == 15
    assert recorder.rows_lost == 25
    result = recorder.stop(wait_s=5.0)
    assert result["complete"] is False
    assert result["rows_lost"] == 25 and result["rows_written"] == 15 and result["rows"] == 40
    assert recorder.status()["last"] == {k: result[k] for k in recorder.last}  # type: ignore[union-attr]
    assert "# lost: 25 rows before row 25" in path.read_text()


def test_stop_does_not_wait_for_the_writer(recorder: Recorder, tmp_path: Path) -> None:
    recorder.start(tmp_path / "slow.csv", {"test": "slow writer"})
    for k in range(10):
        recorder.push_tick(k / 100, 3)
    pid = _stalled(recorder)
    try:
        stopped = recorder.stop()  # returns at once although the writer cannot run
        assert stopped["closing"] and stopped["rows"] == 10 and not recorder.active
        recorder.reap()
        assert recorder.closing and recorder.last is None
    finally:
        os.kill(pid, signal.SIGCONT)
    recorder.reap(wait_s=5.0)
    assert not recorder.closing
    assert recorder.last == {"path": str(tmp_path / "slow.csv"), "rows": 10, "rows_written": 10,
                             "rows_lost": 0, "complete": True}


def test_a_thread_writer_left_draining_at_shutdown_keeps_its_ring(tmp_path: Path,
                                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    """close() gives up waiting on a writer thread still draining: the ring it reads is not
    closed under it; the thread writes every row, then closes its file and the ring."""
    profile = load_profile()
    hand = rtcore.Hand(profile.hand_config())
    rec = Recorder(profile.finger_names, 100.0, kind="thread")
    rec.bind(hand.c_inputs, hand.c_outputs, np.zeros(len(profile.fingers)))
    path = tmp_path / "thread.csv"
    rec.start(path, {"test": "thread writer left draining"})
    for k in range(30):
        rec.push_tick(k / 100, 3)
    writer = rec._thread
    assert writer is not None
    drainer = writer.drainer
    release = threading.Event()
    flush = Drainer.flush

    def held_flush(self: Drainer, sync: bool = False) -> None:
        if sync:  # the last drain waits for the test
            assert release.wait(10)
        flush(self, sync)

    monkeypatch.setattr(Drainer, "flush", held_flush)
    rec.close(wait_s=0.01)
    assert rec.last is not None and rec.last["complete"] is False  # it went on alone
    assert drainer.ring.rows is not None and not drainer.out.closed
    release.set()
    assert writer.join(5.0)
    assert drainer.rows_written == 30
    assert drainer.out.closed and drainer.ring.rows is None  # the thread closed both
    lines = [ln for ln in path.read_text().splitlines() if not ln.startswith("#")]
    assert len(lines) == 1 + 30  # the header, then every row


def test_the_writer_syncs_on_request_and_periodically_only_when_asked(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Flushed to the OS every drain; fdatasync on flush(sync=True) (faults, signals, the
    end) and, with sync_every_s, when that long has passed."""
    from rtcore.ring import Ring

    synced: list[int] = []
    monkeypatch.setattr(os, "fdatasync", synced.append)
    ring = Ring(tmp_path / "ring", ring_columns(5), 16)
    with open(tmp_path / "out.csv", "w") as out:
        plain = Drainer(ring, out, load_profile().finger_names)
        plain._last_sync -= 100.0  # long ago
        plain.flush()
        assert synced == []
        plain.flush(sync=True)
        assert synced == [out.fileno()]
        periodic = Drainer(ring, out, load_profile().finger_names, sync_every_s=0.5)
        periodic.flush()
        assert len(synced) == 1  # not yet due
        periodic._last_sync -= 0.6
        periodic.flush()
        assert len(synced) == 2
    ring.close()


def test_the_sync_interval_reaches_the_writer_process(tmp_path: Path) -> None:
    profile = load_profile()
    hand = rtcore.Hand(profile.hand_config())
    rec = Recorder(profile.finger_names, 100.0, sync_every_s=0.25)
    rec.bind(hand.c_inputs, hand.c_outputs, np.zeros(len(profile.fingers)))
    rec.start(tmp_path / "rec.csv", {})
    try:
        pid = rec.writer_pid
        assert pid is not None
        cmdline = Path(f"/proc/{pid}/cmdline")
        wait_for(lambda: b"recorder_writer" in cmdline.read_bytes(), 5.0, "the writer to exec")
        argv = cmdline.read_bytes().split(b"\0")
        assert argv[argv.index(b"--sync-every-s") + 1] == b"0.25"
    finally:
        rec.close(wait_s=5.0)
    with pytest.raises(UserError, match="positive number of seconds"):
        Recorder(profile.finger_names, 100.0, sync_every_s=0.0)


def test_the_thread_writer_syncs_when_flushed(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """flush() (a fault, a signal) is an fdatasync for the thread writer too."""
    from hand_service.service.recorder_writer import WriterThread
    from rtcore.ring import Ring

    synced: list[int] = []
    monkeypatch.setattr(os, "fdatasync", synced.append)
    ring = Ring(tmp_path / "ring", ring_columns(5), 16)
    with open(tmp_path / "out.csv", "w") as out:
        writer = WriterThread(Drainer(ring, out, load_profile().finger_names))
        try:
            writer.flush()
            wait_for(lambda: synced, 5.0, "an fdatasync after flush()")
        finally:
            writer.request_stop()
            assert writer.join(5.0)
    ring.close()


def test_the_simulated_hands_true_angle_is_recorded_beside_the_measured_one(tmp_path: Path) -> None:
    """angle_true_deg_<f> is the simulator's angle at the sample the tick read: the measured
    angle differs from it by the sensor's noise (and its ADC step), no more, with no lag."""
    from hand_service.bench.tick import sweep_trajectory
    from hand_service.recording import read_recording
    from hand_service.service.states import Event, State
    from hand_service.service.supervisor import Supervisor
    from hand_service.transports import transport_class
    from rtcore import clock

    profile = load_profile()
    rate_hz = profile.control.rate_hz
    rec = Recorder(profile.finger_names, rate_hz, kind="thread")
    sup = Supervisor(profile, transport_class("sim")(profile), rec)
    path = tmp_path / "truth.csv"
    rec.start(path, {"test": "true angle"})
    sup.set_trajectory(sweep_trajectory(len(profile.fingers), rate_hz), loop=True)
    sup.schedule = schedule = clock.Schedule(sup.period_ns)
    try:
        while sup.state is not State.DISARMED:
            assert schedule.index < 50, sup.state
            sup.run_one(schedule)
        sup.fire(Event.ARM)
        sup.fire(Event.START)
        for _ in range(round(3.0 * rate_hz)):
            sup.run_one(schedule)
    finally:
        sup.request_stop("test done")
        sup.shutdown()
    noise_deg = profile.simulation["sensor_noise_deg"]
    for finger in profile.finger_names:
        r = read_recording(path, finger=finger)
        running = np.array([s == "RUNNING" for s in r.text_columns["state"]])
        measured, true = r.angle_deg[running], r.columns["angle_true_deg"][running]
        assert running.sum() >= 2.5 * rate_hz
        # every row, the ones Python pushes too (INIT, the shutdown's): the simulator's truth
        assert np.isfinite(r.columns["angle_true_deg"]).all() and r.text_columns["state"][-1] == "SHUTDOWN"
        assert np.ptp(true) > 20.0, finger  # the sweep moves it: a column of zeros would not do
        error = measured - true
        assert abs(error.mean()) < 0.1 and 0.8 * noise_deg < error.std() < 1.25 * noise_deg, (
            finger, error.mean(), error.std())


@pytest.mark.parametrize("kind", ["thread", "process"])
def test_the_ring_keeps_its_name_while_recording_and_a_dead_daemons_ring_goes(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, kind: str) -> None:
    """status()["ring_path"] names the ring (0600) while the recording runs, for the live
    view; stop() removes the name. A ring whose daemon is gone (both it and its writer were
    killed) is removed when this user's next recording allocates its own."""
    import subprocess
    import sys

    from hand_service.service.recording_ring import RING_DIR_ENV, RING_PREFIX

    monkeypatch.setenv(RING_DIR_ENV, str(tmp_path))
    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait()
    stale = tmp_path / f"{RING_PREFIX}{gone.pid}-left"
    alive = tmp_path / f"{RING_PREFIX}{os.getppid()}-other"  # a live daemon's: kept
    stale.write_bytes(b"x")
    alive.write_bytes(b"x")
    profile = load_profile()
    hand = rtcore.Hand(profile.hand_config())
    rec = Recorder(profile.finger_names, 100.0, kind=kind)
    rec.bind(hand.c_inputs, hand.c_outputs, np.zeros(len(profile.fingers)))
    rec.start(tmp_path / "rec.csv", {})
    try:
        ring = Path(str(rec.status()["ring_path"]))
        assert ring.parent == tmp_path and ring.name.startswith(f"{RING_PREFIX}{os.getpid()}-")
        assert ring.stat().st_mode & 0o777 == 0o600
        assert not stale.exists() and alive.exists()
        for k in range(5):
            rec.push_tick(k / 100, 3)
        rec.stop(wait_s=5.0)
        assert not ring.exists()
    finally:
        rec.close(wait_s=5.0)
    assert rec.last is not None and rec.last["rows_written"] == 5


@pytest.mark.parametrize(("file_mode", "umask"), [(None, 0o022), (0o600, 0o022), (0o664, 0o077)])
def test_a_recording_is_created_with_its_file_mode_whatever_the_umask(
        tmp_path: Path, file_mode: int | None, umask: int) -> None:
    """0640 by default (it was 0644: every local user could read the lab's runs); the
    profile's recording.file_mode otherwise, the daemon's umask not taken from it."""
    profile = load_profile()
    hand = rtcore.Hand(profile.hand_config())
    extra = {} if file_mode is None else {"file_mode": file_mode}
    rec = Recorder(profile.finger_names, 100.0, kind="thread", **extra)
    rec.bind(hand.c_inputs, hand.c_outputs, np.zeros(len(profile.fingers)))
    old = os.umask(umask)
    try:
        rec.start(tmp_path / "rec.csv", {})
        rec.stop(wait_s=5.0)
    finally:
        os.umask(old)
        rec.close(wait_s=5.0)
    expected = 0o640 if file_mode is None else file_mode
    assert (tmp_path / "rec.csv").stat().st_mode & 0o777 == expected
    assert load_profile().recording.file_mode_bits == 0o640
