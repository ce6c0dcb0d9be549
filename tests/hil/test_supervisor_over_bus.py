"""The supervisor daemon over each bus against the mock firmware: the same code that
runs the simulated hand, unchanged, holds a finger at a target through the valve board.

On the virtual bus (in-process only) the supervisor runs in this process; over SLCAN and
serial the real `hand-service run` process talks to the mock in another process, driven
through its control socket like a lab script would."""

from __future__ import annotations

import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
import yaml

from hand_service.config.profile import PROFILE_DIR, load_profile
from hand_service.firmware.rig import RIG_PROFILES, Rig
from hand_service.recording import read_recording
from hand_service.service.states import Event, State
from hand_service.service.supervisor import Supervisor
from rtcore import MODE_POSITION, clock
from tests.service.process import DaemonProcess

TARGET_DEG = 40.0
# This test holds a target; it does not test the sample-age bound (the fault matrix does).
# With the profile's 100 ms, one stall of the mock's process on a loaded CI machine (107 ms,
# beside the CPU-bound tests) faulted sample_late and failed a run.
SAMPLE_AGE_MAX_MS = 500


def tolerant_profile(name: str, tmp_path: Path) -> Path:
    """The rig's shipped profile with SAMPLE_AGE_MAX_MS in its safety section, written to
    `tmp_path`: the mock and the daemon both read it from that file."""
    shipped = PROFILE_DIR / RIG_PROFILES[name]
    data = yaml.safe_load(shipped.read_text())
    included = PROFILE_DIR / data["include"]
    safety = dict(yaml.safe_load(included.read_text())["safety"])
    safety["sample_age_max_ms"] = SAMPLE_AGE_MAX_MS
    data.update(include=str(included), safety=safety)
    if "dbc" in data["transport"]:  # relative to the profile, like the include
        data["transport"]["dbc"] = str(PROFILE_DIR / data["transport"]["dbc"])
    path = tmp_path / RIG_PROFILES[name]
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


@pytest.fixture(params=sorted(RIG_PROFILES))
def rig(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[Rig]:
    profile = load_profile(tolerant_profile(request.param, tmp_path))
    assert profile.safety["sample_age_max_ms"] == SAMPLE_AGE_MAX_MS
    with Rig(request.param, tmp_path, profile) as bench_rig:
        yield bench_rig


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
