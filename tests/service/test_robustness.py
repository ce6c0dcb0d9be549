"""The daemon under what should never happen: an exception escaping the loop still
vents, records the vented tick, closes the recording and the link. And a trajectory
restarts on every start (a resume continues it)."""

from __future__ import annotations

from pathlib import Path

import pytest

from hand_service.config.profile import load_profile
from hand_service.recording import read_recording
from hand_service.service.recorder import Recorder
from hand_service.service.states import Event, State
from hand_service.service.supervisor import Supervisor
from hand_service.service.trajectory_csv import read_trajectory
from tests.service.conftest import Rig
from tests.service.fakes import FaultyTransport

INDEX = 1  # sim.yaml: thumb index middle ring little


def test_an_exception_in_the_loop_still_vents_and_closes_the_recording(tmp_path: Path) -> None:
    profile = load_profile(None)
    transport = FaultyTransport(profile)
    sup = Supervisor(profile, transport, Recorder(profile.finger_names, 100.0))
    record = tmp_path / "crash.csv"
    sup.recorder.start(record, {"profile": "sim"})

    def slack(_slack_ns: int) -> None:
        ticks = sup.stats.ticks
        if ticks == 2:
            sup.fire(Event.ARM)
            sup.targets.mode[:] = 1  # pressure
            sup.targets.pressure_kpa[:] = 40.0
            sup.fire(Event.START)
        if ticks == 130:
            at_crash.update(vents=transport.vents, sent_kpa=float(transport.sent[-1].max()))
            raise RuntimeError("a bug in a slack job")

    at_crash: dict[str, float] = {}
    sup.slack.append(slack)
    with pytest.raises(RuntimeError, match="a bug in a slack job"):
        sup.run(max_ticks=1000)
    assert sup.state is State.RUNNING  # the loop died pressurised ...
    assert sup.stop_reason == "RuntimeError in the loop"
    assert at_crash["sent_kpa"] > 10.0
    assert transport.vents > at_crash["vents"]  # ... and shutdown vented all the same
    assert not sup.link_open
    assert not sup.recorder.active
    rec = read_recording(record, finger="index")
    assert rec.columns["pressure_kpa"].max() > 10.0
    assert rec.columns["pressure_kpa"][-1] == 0.0  # the vented tick is the last row
    assert rec.text_columns["mode"][-1] == "vent"


TRAJECTORY = "t,angle_ref_deg_index\n0,0\n0.5,30\n1.0,30\n"  # 101 ticks, a ramp then a plateau


@pytest.fixture
def traj_rig(tmp_path: Path) -> Rig:
    path = tmp_path / "ramp.csv"
    path.write_text(TRAJECTORY)
    rig = Rig()
    rig.tick()  # the handshake
    rig.sup.set_trajectory(read_trajectory(str(path), rig.profile, rig.sup.rate_hz))
    return rig


def _start(rig: Rig) -> None:
    rig.sup.fire(Event.ARM)
    rig.sup.fire(Event.START)


def _index_ref_deg(rig: Rig) -> float:
    return float(rig.sup.hand.inputs.angle_ref_deg[INDEX])


def test_start_plays_the_trajectory_from_its_start_after_disarm(traj_rig: Rig) -> None:
    _start(traj_rig)
    traj_rig.tick(30)
    assert _index_ref_deg(traj_rig) == pytest.approx(29 * 0.6)  # 30 deg in 50 ticks
    traj_rig.sup.fire(Event.DISARM)
    traj_rig.tick(5)
    _start(traj_rig)
    traj_rig.tick()
    assert _index_ref_deg(traj_rig) == 0.0  # not 30 ticks in: no jump in the reference
    assert traj_rig.sup.trajectory_tick == 1


def test_start_after_fault_and_reset_plays_from_the_start(traj_rig: Rig) -> None:
    _start(traj_rig)
    traj_rig.tick(20)
    traj_rig.transport.lost = True
    traj_rig.tick()
    assert traj_rig.sup.state is State.FAULT
    traj_rig.transport.lost = False
    traj_rig.sup.reset()
    traj_rig.tick()  # INIT: the handshake again
    assert traj_rig.sup.state is State.DISARMED
    _start(traj_rig)
    traj_rig.tick()
    assert _index_ref_deg(traj_rig) == 0.0


def test_a_finished_trajectory_replays_on_the_next_start(traj_rig: Rig) -> None:
    _start(traj_rig)
    traj_rig.tick(110)
    assert traj_rig.sup.state is State.HOLD and traj_rig.sup.trajectory_done
    traj_rig.sup.fire(Event.DISARM)
    _start(traj_rig)
    assert not traj_rig.sup.trajectory_done
    traj_rig.tick(10)
    assert _index_ref_deg(traj_rig) == pytest.approx(9 * 0.6)
    traj_rig.tick(110)
    assert traj_rig.sup.trajectory_done  # and it ran to its end again


def test_resume_after_hold_continues_where_it_paused(traj_rig: Rig) -> None:
    _start(traj_rig)
    traj_rig.tick(20)
    traj_rig.sup.fire(Event.HOLD)
    traj_rig.tick(30)
    assert _index_ref_deg(traj_rig) == pytest.approx(19 * 0.6)  # frozen
    traj_rig.sup.fire(Event.RESUME)
    traj_rig.tick()
    assert _index_ref_deg(traj_rig) == pytest.approx(20 * 0.6)  # the next tick of the ramp
