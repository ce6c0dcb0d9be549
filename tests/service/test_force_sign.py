"""A negative force target: the loop tracks the signed normal force (docs/physics.md §3), and
the recording's force_est_n and the status's force_est_n are that signed force, in the
same convention as force_ref_n, never its magnitude."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hand_service.api.requests import Api
from hand_service.recording import read_recording
from hand_service.service.states import State
from tests.service.conftest import Rig

HELD_DEG = 30.0  # an object behind the index finger keeps it from straightening
TARGET_N = -1.0  # press back on it with 1 N less than the finger's spring would


def test_a_negative_force_target_is_recorded_and_reported_negative(tmp_path: Path) -> None:
    rig = Rig()
    rig.profile.safety["target_force_min_n"] = -2.0  # this rig allows pressing back (docs/api.md)
    # the finger rests on the object: the sensor reads HELD_DEG whatever the chamber does
    # (while it presses back on it, which it does below kθ/N of pressure)
    rig.transport.sensor_override = np.array(
        [(HELD_DEG - f.sensor_offset_deg) / f.sensor_gain_deg_per_mv for f in rig.profile.fingers])
    api = Api(rig.sup, metadata=lambda: {"test": "negative force target"}, record_dir=tmp_path)
    record = tmp_path / "force.csv"

    def ok(request: dict[str, object]) -> dict[str, object]:
        reply = api.handle(request)
        assert isinstance(reply, dict) and reply["ok"], reply
        return reply

    def run(ticks: int) -> None:
        for _ in range(ticks):  # the supervisor's time, as its loop would set it
            rig.sup.t_s = rig.sup.tick_index / rig.sup.rate_hz
            rig.tick()
            rig.sup.tick_index += 1

    run(1)  # the handshake
    try:
        ok({"cmd": "record_start", "path": str(record)})
        ok({"cmd": "arm"})
        ok({"cmd": "target", "finger": "index", "force_n": TARGET_N})
        ok({"cmd": "start"})
        run(300)
        assert rig.sup.state is State.RUNNING, rig.sup.faults.faults
        status = ok({"cmd": "status"})["result"]["fingers"]["index"]  # type: ignore[index]
    finally:
        rig.sup.recorder.close(wait_s=5.0)
    assert rig.sup.recorder.last is not None and rig.sup.recorder.last["complete"]

    # the loop tracks -1 N (a chamber above 0 kPa holds it there) ...
    assert status["mode"] == "force" and status["force_ref_n"] == TARGET_N
    assert -1.6 < status["force_est_n"] < -0.4  # one tick's estimate, 0.5 kPa of sensor noise
    assert status["pressure_cmd_kpa"] > 5.0
    # ... and the recording says so, sign and all
    rec = read_recording(record, finger="index")
    held = rec.t_s >= 2.0
    assert held.sum() >= 90
    np.testing.assert_array_equal(rec.columns["force_ref_n"][held], TARGET_N)
    force_n = rec.columns["force_est_n"][held]
    assert np.all(force_n < 0.0), force_n
    assert abs(np.mean(force_n) - TARGET_N) < 0.1
    assert rec.columns["force_est_n"][-1] == pytest.approx(status["force_est_n"], rel=1e-5)
