"""Impedance mode through the daemon's API: `mode index impedance` with a stiffness, the
finger held short of its target angle by an object, presses with stiffness x shortfall."""

from __future__ import annotations

import numpy as np
import pytest

from hand_service.api.requests import Api
from hand_service.service.states import State
from tests.daemon.conftest import Rig

HELD_DEG = 30.0  # an object keeps the index finger here
TARGET_DEG = 40.0
STIFFNESS_N_PER_DEG = 0.1


def test_impedance_presses_with_the_set_stiffness_times_the_shortfall() -> None:
    rig = Rig()
    rig.transport.sensor_override = np.array(
        [(HELD_DEG - f.sensor_offset_deg) / f.sensor_gain_deg_per_mv for f in rig.profile.fingers])
    api = Api(rig.sup, metadata=lambda: {"test": "impedance"})

    def reply(request: dict[str, object]) -> dict[str, object]:
        answer = api.handle(request)
        assert isinstance(answer, dict)
        return answer

    def run(ticks: int) -> None:
        for _ in range(ticks):
            rig.sup.t_s = rig.sup.tick_index / rig.sup.rate_hz
            rig.tick()
            rig.sup.tick_index += 1

    run(1)
    for request in ({"cmd": "arm"}, {"cmd": "target", "finger": "index", "angle_deg": TARGET_DEG},
                    {"cmd": "mode", "finger": "index", "mode": "impedance",
                     "stiffness_n_per_deg": STIFFNESS_N_PER_DEG}, {"cmd": "start"}):
        assert reply(request)["ok"], request
    estimates = []
    for _ in range(20):
        run(10)
        estimates.append(reply({"cmd": "status"})["result"]["fingers"]["index"])  # type: ignore[index]
    assert rig.sup.state is State.RUNNING, rig.sup.faults.faults
    status = estimates[-1]
    assert status["mode"] == "impedance" and status["angle_ref_deg"] == TARGET_DEG
    force_n = np.mean([s["force_est_n"] for s in estimates[10:]])  # noise: 0.5 kPa of pressure
    assert force_n == pytest.approx(STIFFNESS_N_PER_DEG * (TARGET_DEG - HELD_DEG), abs=0.15)


@pytest.mark.parametrize(("request_", "error"), [
    ({"mode": "impedance"}, "mode impedance needs stiffness_n_per_deg"),
    ({"mode": "force", "stiffness_n_per_deg": 0.1}, "go with mode impedance only"),
    ({"mode": "impedance", "stiffness_n_per_deg": -0.1}, "'stiffness_n_per_deg' must be 0 or more"),
    ({"mode": "impedance", "stiffness_n_per_deg": 0.1, "damping_n_s_per_deg": "x"}, "finite number"),
])
def test_impedance_requests_refused_with_a_reason(request_: dict[str, object], error: str) -> None:
    api = Api(Rig().sup, metadata=lambda: {})
    answer = api.handle({"cmd": "mode", "finger": "index", **request_})
    assert isinstance(answer, dict) and not answer["ok"] and error in answer["error"], answer
