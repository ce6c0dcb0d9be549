"""Impedance mode through the daemon's API: `mode index impedance` with a stiffness, the
finger held short of its target angle by an object, presses with stiffness x shortfall."""

from __future__ import annotations

import numpy as np
import pytest

from hand_service.api.impedance import gain_limits
from hand_service.api.requests import Api
from hand_service.cli import main
from hand_service.service.states import State
from rtcore import MODE_IMPEDANCE
from tests.service.conftest import Rig

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
    ({"mode": "impedance", "stiffness_n_per_deg": 1e308}, "above index's stable limit 0.123 N/deg"),
    ({"mode": "impedance", "stiffness_n_per_deg": 5e5}, "'stiffness_n_per_deg' = 500000 is above"),
    ({"mode": "impedance", "stiffness_n_per_deg": 0.1, "damping_n_s_per_deg": 0.01},
     "'damping_n_s_per_deg' = 0.01 is above index's stable limit 0.00104"),
])
def test_impedance_requests_refused_with_a_reason(request_: dict[str, object], error: str) -> None:
    api = Api(Rig().sup, metadata=lambda: {})
    answer = api.handle({"cmd": "mode", "finger": "index", **request_})
    assert isinstance(answer, dict) and not answer["ok"] and error in answer["error"], answer


def test_gains_above_any_fingers_limit_are_refused_for_all_and_nothing_changes() -> None:
    rig = Rig()
    api = Api(rig.sup, metadata=lambda: {})
    limits = {f.name: gain_limits(f.model) for f in rig.profile.fingers}
    lowest = min(limits, key=lambda name: limits[name][0])
    k_lowest = limits[lowest][0]
    before = np.array(rig.sup.hand.inputs.impedance_stiffness_n_per_deg)
    answer = api.handle({"cmd": "mode", "finger": "all", "mode": "impedance",
                         "stiffness_n_per_deg": 1.01 * k_lowest})
    assert isinstance(answer, dict) and not answer["ok"] and f"above {lowest}'s" in answer["error"], answer
    assert np.array_equal(rig.sup.hand.inputs.impedance_stiffness_n_per_deg, before)
    assert rig.sup.targets.mode[rig.sup.names.index(lowest)] != MODE_IMPEDANCE  # not switched either
    answer = api.handle({"cmd": "mode", "finger": "all", "mode": "impedance",
                         "stiffness_n_per_deg": 0.99 * k_lowest})
    assert isinstance(answer, dict) and answer["ok"], answer


def test_an_angle_target_keeps_an_impedance_finger_in_impedance() -> None:
    """The angle is impedance mode's reference: `target --angle-deg` moves it, the mode stays;
    a finger in another mode goes to position as before."""
    rig = Rig()
    api = Api(rig.sup, metadata=lambda: {})
    names = rig.sup.names
    assert api.handle({"cmd": "mode", "finger": "index", "mode": "impedance",
                       "stiffness_n_per_deg": STIFFNESS_N_PER_DEG})["ok"]  # type: ignore[index]
    answer = api.handle({"cmd": "target", "finger": "index", "angle_deg": 30.0})
    assert isinstance(answer, dict) and answer["ok"] and answer["result"]["mode"] == "impedance", answer
    index = names.index("index")
    assert rig.sup.targets.mode[index] == MODE_IMPEDANCE and rig.sup.targets.angle_deg[index] == 30.0
    answer = api.handle({"cmd": "target", "finger": "all", "angle_deg": 35.0})
    assert isinstance(answer, dict) and answer["ok"], answer
    modes = answer["result"]["mode"]
    assert modes == {name: "impedance" if name == "index" else "position" for name in names}, modes
    # a force or pressure target is not an angle: it leaves impedance, as it leaves position
    answer = api.handle({"cmd": "target", "finger": "index", "force_n": 0.5})
    assert isinstance(answer, dict) and answer["result"]["mode"] == "force", answer


@pytest.mark.parametrize(("value", "flag"), [("nan", "--stiffness"), ("inf", "--stiffness"),
                                             ("-0.1", "--stiffness"), ("nan", "--damping")])
def test_ctl_refuses_a_gain_that_is_not_finite_or_negative_before_sending(
        value: str, flag: str, capsys: pytest.CaptureFixture[str], tmp_path: object) -> None:
    argv = ["ctl", "--socket", f"{tmp_path}/none.sock", "mode", "index", "impedance", "--stiffness", "0.1"]
    argv += [flag, value] if flag == "--damping" else []
    if flag == "--stiffness":
        argv[-1] = value
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert f"{flag} must be a finite number, 0 or more" in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1
