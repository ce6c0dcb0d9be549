"""The two ways a tick reaches the valves give the same hand, tick for tick: on the
simulated hand the whole tick is one C call (rtcore_tick_sim), on any other transport the
tick calls the transport in Python around the C control and follow halves."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from hand_service.bench.tick import sweep_trajectory
from hand_service.config.profile import load_profile
from hand_service.service.bus_tick import PythonTickPath
from hand_service.service.recorder import Recorder
from hand_service.service.states import Event, State
from hand_service.service.supervisor import Supervisor
from hand_service.service.tick_path import CoreTickPath
from hand_service.transports import SensorSample
from hand_service.transports.sim import SimTransport
from rtcore import MODE_POSITION
from tests.service.fakes import FaultyTransport


class PythonPathSim(SimTransport):
    """The simulated hand, but its sample goes through Python: no core link."""

    tick_in_core = False

    def latest(self) -> SensorSample | None:
        return super().latest()


def _run(transport: SimTransport) -> tuple[list[tuple[object, ...]], Supervisor]:
    profile = transport.profile
    sup = Supervisor(profile, transport, Recorder(profile.finger_names, 100.0))
    n = len(profile.fingers)
    traj = sweep_trajectory(n, 100.0)
    traj.mode[:, 3:] = -1  # the last fingers follow their targets
    sup.set_trajectory(traj)
    sup.targets.mode[:] = MODE_POSITION
    sup.targets.angle_deg[:] = 25.0
    trace = []
    now_ns = 10**9
    for k in range(700):
        if k == 1:
            sup.fire(Event.ARM)
        elif k == 3:
            sup.fire(Event.START)
        elif k == 500:  # a core configured with a looser limit than the profile's
            config = sup.hand.config
            loose = [dataclasses.replace(f, pressure_max_kpa=f.pressure_max_kpa + 100.0)
                     for f in config.fingers]
            sup.hand.configure(dataclasses.replace(config, fingers=loose))
            sup.fire(Event.RESUME)
            sup.targets.mode[0] = 1  # pressure, over the profile's limit
            sup.targets.pressure_kpa[0] = profile.fingers[0].pressure_max_kpa + 50.0
        sup.tick_index, sup.t_s = k, k / 100.0
        sup.tick(now_ns)
        now_ns += sup.period_ns
        inputs, outputs = sup.hand.inputs, sup.hand.outputs
        trace.append((sup.state, sup.trajectory_tick, sup.sent_kpa.copy(), inputs.mode.copy(),
                      inputs.angle_ref_deg.copy(), inputs.velocity_ref_deg_per_s.copy(),
                      outputs.angle_filt_deg.copy(), outputs.pressure_cmd_kpa.copy()))
    return trace, sup


def test_the_c_tick_and_the_python_transport_path_agree() -> None:
    profile = load_profile(None)
    core_trace, core = _run(SimTransport(profile, seed=3))
    py_trace, py = _run(PythonPathSim(profile, seed=3))
    assert isinstance(core.path, CoreTickPath) and isinstance(py.path, PythonTickPath)
    states = [row[0] for row in core_trace]
    # the run passes through every phase: the sweep, its end (HOLD), resumed, then a fault
    assert {State.RUNNING, State.HOLD, State.FAULT} <= set(states)
    assert max(row[2].max() for row in core_trace) > 0.0
    for k, (a, b) in enumerate(zip(core_trace, py_trace, strict=True)):
        assert a[0] is b[0] and a[1] == b[1], f"tick {k}: {a[:2]} vs {b[:2]}"
        for x, y in zip(a[2:], b[2:], strict=True):
            np.testing.assert_array_equal(x, y, err_msg=f"tick {k}")
    assert [f.as_dict() | {"wall_time": ""} for f in core.faults.faults] == \
           [f.as_dict() | {"wall_time": ""} for f in py.faults.faults]
    assert core.faults.faults[-1].cause.value == "pressure_over_limit"
    assert core.transport.health().frames_out == py.transport.health().frames_out > 600


@pytest.mark.parametrize("cls, in_core", [(SimTransport, True), (PythonPathSim, False),
                                         (FaultyTransport, False)])
def test_only_the_plain_simulated_hand_runs_in_core(cls: type[SimTransport], in_core: bool) -> None:
    """A subclass that changes what crosses the wire keeps its Python path, so its
    overrides are never skipped."""
    assert (cls(load_profile(None)).core_link() is not None) is in_core


def test_a_subclass_that_changes_the_wire_must_say_how_it_ticks() -> None:
    """Overriding what crosses the wire while keeping the C tick would skip the override:
    such a class is refused when it is defined."""
    with pytest.raises(TypeError, match="tick_in_core = False"):
        class Sneaky(SimTransport):
            def send(self, pressure_cmd_kpa: np.ndarray) -> None:
                super().send(pressure_cmd_kpa)
