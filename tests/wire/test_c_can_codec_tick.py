"""The tick over can-v1 in C (rtcore_can_tick) against the Python path it replaces: for any
stream of sample frames (in order, lost, duplicated, old, corrupted), the same samples taken
(SampleMonitor's rule), the same step, the same events and the same command frames as
CanCodec + SampleMonitor + the two C halves + CanCodec.encode; and end to end, the
supervisor ticking in C over python-can's virtual bus against the mock firmware."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import rtcore
from hand_service import cli
from hand_service.config.profile import load_profile
from hand_service.service.safety import SafetyGate
from hand_service.transports.base import TransportHealth
from hand_service.transports.monitor import SampleMonitor
from hand_service.wire.can_c_codec import new_core
from hand_service.wire.can_codec import CanCodec
from hand_service.wire.messages import SensorReport, ValveCommand
from rtcore import clock
from rtcore.can import PHASES, CanTickCore, tx_frames
from rtcore.tick import REFS_RUN, Tick

PROFILE = load_profile("can-v1-virtual.yaml")
N = len(PROFILE.fingers)
PERIOD_NS = 10_000_000


def _tick() -> tuple[Tick, rtcore.Hand]:
    hand = rtcore.Hand(PROFILE.hand_config())
    tick = Tick(hand, SafetyGate(PROFILE).core, N)
    tick.targets.mode[:] = rtcore.MODE_POSITION
    tick.targets.angle_deg[:] = 35.0
    return tick, hand


reading = st.one_of(st.floats(500.0, 4000.0), st.just(0.0), st.just(6553.5))
pressure = st.one_of(st.floats(0.0, 150.0), st.just(math.nan))
step = st.sampled_from([1, 1, 1, 1, 0, 2, 3, 200])  # in order, a duplicate, gaps, an old one


@st.composite
def ticks(draw: st.DrawFn) -> list[list[tuple[int, list[float], list[float], bool]]]:
    """Per tick, the samples that arrived: (sequence step, mV, kPa, one frame corrupted)."""
    return draw(st.lists(st.lists(st.tuples(step, st.lists(reading, min_size=N, max_size=N),
                                            st.lists(pressure, min_size=N, max_size=N),
                                            st.sampled_from([True, True, True, False])),
                                  max_size=3), min_size=1, max_size=25))


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(ticks())
def test_the_c_tick_takes_steps_and_sends_what_the_python_tick_does(stream: list) -> None:  # type: ignore[type-arg]
    dbc = PROFILE.transport["dbc"]
    codec, encoder = CanCodec(dbc, N), CanCodec(dbc, N)
    monitor = SampleMonitor(PROFILE.finger_names, PROFILE.transport, 1.0, TransportHealth())
    (py, py_hand), (c, c_hand) = _tick(), _tick()
    batch = CanTickCore(new_core(codec), c.c)
    sequence = 0
    for k, arrived in enumerate(stream):
        woke_ns = (k + 1) * PERIOD_NS
        taken, lost = None, 0
        for delta, mv, kpa, intact in arrived:
            sequence = (sequence + delta) % 256
            frames = encoder.encode(SensorReport(sequence, k, mv, kpa))
            if not intact:  # one finger's frame garbled on the way: that sample never completes
                frames[1].data = bytes([frames[1].data[0] ^ 0x5A]) + bytes(frames[1].data[1:])
            for frame in frames:
                batch.add(frame.arbitration_id, bytes(frame.data), k * 0.01)
                for report in codec.decode(frame):
                    sample = monitor.sample(report, k * 0.01, k)
                    if sample is not None:  # as LinkTransport._handle keeps it for latest()
                        lost = max(lost, sample.lost_in_a_row)
                        taken = sample
        if taken is not None:
            py_hand.inputs.sensor_mv[:] = taken.sensor_mv
            py_hand.inputs.pressure_meas_kpa[:] = taken.pressure_meas_kpa
        events_py = py.control(REFS_RUN, 0, 0, taken is not None, lost, woke_ns)
        sent_py = encoder.encode(ValveCommand(k + 1, list(py.sent_kpa)))
        events_py |= py.follow()
        events_c = batch.tick(REFS_RUN, False, False, woke_ns, k + 1)
        assert events_c == events_py
        assert (batch.samples > 0) == (taken is not None)
        np.testing.assert_array_equal(c_hand.inputs.sensor_mv, py_hand.inputs.sensor_mv)
        np.testing.assert_array_equal(c_hand.inputs.pressure_meas_kpa, py_hand.inputs.pressure_meas_kpa)
        np.testing.assert_array_equal(c.sent_kpa, py.sent_kpa)
        assert tx_frames(batch.tx()) == [(f.arbitration_id, bytes(f.data)) for f in sent_py]


def test_a_vent_or_a_fault_sends_zero_kpa_frames() -> None:
    tick, _ = _tick()
    codec = CanCodec(PROFILE.transport["dbc"], N)
    batch = CanTickCore(new_core(codec), tick.c)
    batch.tick(REFS_RUN, True, False, PERIOD_NS, 7)  # the caller's own fault: vent
    zeros = codec.encode(ValveCommand(7, [0.0] * N))
    assert tx_frames(batch.tx()) == [(f.arbitration_id, bytes(f.data)) for f in zeros]


def test_a_full_batch_counts_what_it_drops() -> None:
    tick, _ = _tick()
    batch = CanTickCore(new_core(CanCodec(PROFILE.transport["dbc"], N)), tick.c)
    added = sum(batch.add(0x110, bytes(8), 0.0) for _ in range(300))
    assert added == 256 and batch.dropped == 44
    batch.tick(REFS_RUN, False, False, PERIOD_NS, 1)  # decodes (and empties) the batch
    assert batch.add(0x110, bytes(8), 0.0)


def test_the_tick_times_its_phases_inside_its_own_time() -> None:
    """rtcore_can_tick_at: each phase's time is set, and together they fit between the
    wake-up and the end it reports (times_ns), tick after tick."""
    tick, _ = _tick()
    codec = CanCodec(PROFILE.transport["dbc"], N)
    batch = CanTickCore(new_core(codec), tick.c)
    times = Tick.times()
    for k in range(1, 4):
        for frame in codec.encode(SensorReport(k, k, [1000.0] * N, [20.0] * N)):
            batch.add(frame.arbitration_id, bytes(frame.data), 0.0)
        batch.io.phase_ns[0:len(PHASES)] = [-1] * len(PHASES)
        assert batch.tick_at(clock.now_ns(), 0, REFS_RUN, False, False, k, times) >= 0
        assert batch.samples == 1
        phases = batch.phase_ns
        assert len(phases) == len(PHASES) and all(ns > 0 for ns in phases), phases
        assert sum(phases) <= times[1] - times[0]


@pytest.mark.parametrize("tick_in_python", [False, True], ids=["c", "python"])
def test_the_bench_over_virtual_can_ticks_both_ways(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                     tick_in_python: bool) -> None:
    """The supervisor against the mock firmware, the tick in C (the default) or in Python
    (--tick-in-python). Faults are not judged here: this file runs with make test's CPU-bound
    tests at nice 19, where a late sample is the scheduler's doing (the fault matrix and
    tests/hil judge the C tick's faults at normal priority)."""
    out = tmp_path / "bench.json"
    argv = ["bench", "--quick", "--seconds", "1.5", "--no-realtime", "--recorder", "off",
            "--profile", "can-v1-virtual.yaml", "--json", str(out)] + (["--tick-in-python"] * tick_in_python)
    assert cli.main(argv) == 0, capsys.readouterr().err
    figures = json.loads(out.read_text())
    assert figures["tick_path"] == ("python" if tick_in_python else "c")
    assert figures["transport"] == "can" and figures["ticks"] == 150
    assert 0 < figures["tick_ns_p50"] <= figures["tick_ns_p99"]
    for name in PHASES:  # the C tick's phases, timed in the same call; none on the Python path
        p50, p99, top = (figures[f"tick_{name}_ns_{x}"] for x in ("p50", "p99", "max"))
        if tick_in_python:
            assert p50 is None and p99 is None and top is None
        else:
            assert 0 < p50 <= p99 <= top


def test_tick_in_python_is_for_can_profiles_only(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["bench", "--quick", "--profile", "serial-v1.yaml", "--tick-in-python"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--tick-in-python" in err
