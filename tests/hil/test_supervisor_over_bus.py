"""The supervisor daemon over each bus against the mock firmware: the same code that
runs the simulated hand, unchanged, holds a finger at a target through the valve board.

On the virtual bus (in-process only) the supervisor runs in this process; over SLCAN and
serial the real `hand-service run` process talks to the mock in another process, driven
through its control socket like a lab script would."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

from hand_service.firmware.rig import Rig
from hand_service.recording import read_recording
from hand_service.service.states import Event, State
from hand_service.service.supervisor import Supervisor
from rtcore import MODE_POSITION, clock
from tests.service.process import DaemonProcess

TARGET_DEG = 40.0


@pytest.fixture
def rig(tolerant_rig: Rig) -> Rig:
    """This test holds a target; it does not test the sample-age bound (tests/hil/tolerant.py)."""
    return tolerant_rig


def test_supervisor_holds_a_target_through_the_bus(rig: Rig, tmp_path: Path) -> None:
    rig.start_mock()
    index = rig.profile.finger_names.index("index")
    if rig.in_process:
        sup = Supervisor(rig.profile, rig.transport())
        schedule = clock.Schedule(sup.period_ns)
        sup.schedule = schedule
        for _ in range(200):
            if sup.state is State.DISARMED:
                break
            sup.run_one(schedule)
        assert sup.state is State.DISARMED, sup.faults.faults
        sup.targets.mode[index] = MODE_POSITION
        sup.targets.angle_deg[index] = TARGET_DEG
        sup.fire(Event.ARM)
        sup.fire(Event.START)
        angles = []
        for _ in range(300):
            sup.run_one(schedule)
            angles.append(sup.hand.outputs.angle_filt_deg[index])
        assert sup.state is State.RUNNING, sup.faults.faults
        link = sup.status().transport.link  # the round trip on the host's clock, in `status`
        assert link["round_trip_ms"] is not None and 0.0 < link["round_trip_ms"] < link["latency_max_ms"]
        sup.request_stop("test done")
        sup.shutdown()
        assert abs(np.mean(angles[-100:]) - TARGET_DEG) < 2.0
        return

    daemon = DaemonProcess(tmp_path, "--profile", str(rig.profile_path), "--port", rig.channel,
                           "--duration", "30")
    try:
        with daemon.client() as client:
            daemon.disarmed(client)
            client.mode("index", "position")
            client.target("index", angle_deg=TARGET_DEG)
            client.arm()
            client.start()
            time.sleep(3.0)
            status = client.status()
            assert status["state"] == "RUNNING", client.faults()
            link = status["transport"]["link"]
            assert link["round_trip_ms"] is not None and 0.0 < link["round_trip_ms"] < link["latency_max_ms"]
        assert daemon.terminate() == 0, daemon.stderr.read_text()[-2000:]
    finally:
        daemon.close()
    rec = read_recording(daemon.record, finger="index")
    held = rec.columns["angle_filt_deg"][-150:-20]  # the last second or so before SIGTERM
    assert abs(np.mean(held) - TARGET_DEG) < 2.0, np.mean(held)
