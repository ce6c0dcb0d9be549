"""The whole tick in one C call on the plain simulated hand (rtcore_tick_sim): the faults
it can meet there, the hand's time on the host's schedule, and the hand's physics run in
the slack after the tick (run_one), never skipped and never twice."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hand_service.config.profile import load_profile
from hand_service.recording import read_recording
from hand_service.service.recorder import SHUTDOWN_STATE, Recorder
from hand_service.service.states import Event, State
from hand_service.service.supervisor import Supervisor
from hand_service.service.tick_path import CoreTickPath
from hand_service.service.trajectory import CosineSweep, Trajectory
from hand_service.transports.sim import SimTransport
from rtcore import MODE_POSITION, clock


class CoreRig:
    def __init__(self) -> None:
        self.profile = load_profile(None)
        self.transport = SimTransport(self.profile, seed=1)
        self.sup = Supervisor(self.profile, self.transport, Recorder(self.profile.finger_names, 100.0))
        assert isinstance(self.sup.path, CoreTickPath)  # the C path, not the Python one
        self.now_ns = 10**9
        self.period_s = 1.0 / self.sup.rate_hz

    def tick(self, n: int = 1, skip: int = 0) -> None:
        for _ in range(n):
            self.sup.tick_index += 1 + skip
            self.sup.tick(self.now_ns)
            self.sup.path.advance()  # as run_one does in the slack
            self.now_ns += self.sup.period_ns * (1 + skip)

    def running(self) -> None:
        self.sup.tick(self.now_ns)  # INIT: the handshake
        self.sup.fire(Event.ARM)
        self.sup.targets.mode[:] = MODE_POSITION
        self.sup.targets.angle_deg[:] = 30.0
        self.sup.fire(Event.START)
        self.tick(50)
        assert self.sup.state is State.RUNNING, self.sup.faults.faults

    def assert_faulted(self, cause: str, link_open: bool = True) -> None:
        assert self.sup.state is State.FAULT
        assert self.sup.faults.faults[-1].cause.value == cause, self.sup.faults.faults
        assert np.all(self.sup.sent_kpa == 0.0)
        if link_open:  # what the valves hold
            assert np.all(self.transport.simulator.command_kpa == 0.0)


@pytest.fixture
def core() -> CoreRig:
    return CoreRig()


def test_tracks_its_targets(core: CoreRig) -> None:
    core.running()
    core.tick(100)
    np.testing.assert_allclose(core.sup.hand.outputs.angle_filt_deg, 30.0, atol=1.5)
    assert core.transport.health().frames_out == 151  # the handshake's vent, then one per tick


def test_overrun_streak(core: CoreRig) -> None:
    core.running()
    for _ in range(core.profile.safety["overrun_streak"]):
        core.sup.missed_last = True
        core.tick()
    core.assert_faulted("overrun_streak")


def test_angle_out_of_range(core: CoreRig) -> None:
    core.running()
    core.transport.simulator.set_state(2, angle_deg=core.profile.safety["angle_max_deg"] + 20.0)
    core.transport.simulator.sample()  # the reading the next tick takes
    core.tick()
    core.assert_faulted("angle_out_of_range")
    assert core.sup.faults.faults[-1].finger == core.profile.finger_names[2]


def test_a_closed_link_falls_silent(core: CoreRig) -> None:
    core.running()
    core.transport.close()
    silent_ticks = round(core.profile.safety["transport_timeout_ms"] / 1e3 * core.sup.rate_hz)
    core.tick(silent_ticks - 1)
    assert core.sup.state is State.RUNNING
    core.tick()
    core.assert_faulted("transport_lost", link_open=False)  # a closed link takes no command


def test_skipped_deadlines_pass_for_the_hand(core: CoreRig) -> None:
    core.running()
    before_s = core.transport.simulator.time_s
    core.tick(skip=9)  # deadlines skipped by the host: the valves held through them
    after_s = core.transport.simulator.time_s
    assert after_s - before_s == pytest.approx(10 * core.period_s)
    assert core.sup.state is State.RUNNING


def test_the_slack_lives_through_each_period_once() -> None:
    """On the real schedule (run_one): each tick's period is simulated in the slack after
    it, so the hand's time is the schedule's, one period per slot, at every tick. A slot
    that a loaded machine's late tick skipped (stats.skipped) the hand lives through with
    the next command, holding the last one (test_skipped_deadlines_pass_for_the_hand): it
    may lag by those slots after that tick, and by none after the next."""
    core = CoreRig()
    schedule = core.sup.schedule = clock.Schedule(core.sup.period_ns)
    core.sup.run_one(schedule)  # INIT: the handshake
    core.sup.fire(Event.ARM)
    core.sup.fire(Event.START)
    sim = core.transport.simulator
    for _ in range(30):
        skipped_before = core.sup.stats.skipped
        core.sup.run_one(schedule)
        late = core.sup.stats.skipped - skipped_before
        assert core.transport.link.c_link.pending == 0
        assert sim.time_s == pytest.approx((schedule.index - late) * core.period_s)
    core.sup.request_stop("test")
    core.sup.shutdown()  # its vent holds one period more
    assert sim.time_s == pytest.approx((schedule.index + 1) * core.period_s)


def test_the_scheduled_tick_records_every_row(tmp_path: Path) -> None:
    """run() on the simulated hand: the sleep, the tick and its row are one C call, and a
    tick that changes the state (the trajectory's end: HOLD) leaves its row to Python.
    Every slot has one row, in order, with the state after its tick."""
    profile = load_profile(None)
    transport = SimTransport(profile, seed=2)
    recorder = Recorder(profile.finger_names, 100.0, "thread")
    sup = Supervisor(profile, transport, recorder)
    traj = Trajectory.empty(30, len(profile.fingers), 100.0, "short")
    refs = CosineSweep(amplitude_deg=10.0, period_s=0.3).at(np.arange(30) / 100.0)
    for i in range(len(profile.fingers)):
        traj.set_position(slice(None), i, refs)
    sup.set_trajectory(traj)

    def drive(_slack_ns: int) -> None:
        if sup.state is State.DISARMED:
            sup.fire(Event.ARM)
        elif sup.state is State.ARMED:
            sup.fire(Event.START)

    sup.slack.append(drive)
    assert isinstance(sup.path, CoreTickPath)
    python_rows: list[int] = []  # the rows Python pushes: INIT, the tick with events, shutdown
    record = sup.record_row

    def counted(state: int) -> None:
        python_rows.append(state)
        record(state)

    sup.record_row = counted  # type: ignore[method-assign]
    path = tmp_path / "rec.csv"
    recorder.start(path, {"test": "scheduled tick"})
    sup.run(max_ticks=120)
    rec = read_recording(path, finger=profile.finger_names[0])
    states = rec.text_columns.get("state") or [State(int(s)).name for s in rec.columns["state"]]
    slots = np.round(rec.t_s * 100.0).astype(int)
    skipped = sup.stats.skipped
    assert len(rec) == 120 + 1 and slots[0] == 0  # every tick, then the shutdown's vented row
    assert np.all(np.diff(slots) >= 1) and slots[-1] - slots[0] == 120 + skipped
    assert states[:3] == ["DISARMED", "ARMED", "RUNNING"]  # the state after each tick
    hold = states.index("HOLD")  # the tick that found the end: 30 rows played before it
    assert set(states[2:hold]) == {"RUNNING"} and 30 - skipped <= hold - 2 <= 30
    assert set(states[hold:-1]) == {"HOLD"} and states[-1] == "SHUTDOWN"  # the vented last row says so
    assert python_rows == [State.DISARMED, State.HOLD, SHUTDOWN_STATE]  # the other 118 rows: C
