"""Hardware-in-the-loop: the host transports against the mock firmware, over three links.

One class, run over python-can's virtual bus (mock in a thread), SLCAN on a pty and
serial-v1 on a pty (mock in another process each). Timing is never asserted, except
the firmware's watchdog vent: a safety property, with a bound ten times the nominal.
"""

from __future__ import annotations

import logging
import os
import re
import signal
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import numpy as np
import pytest

import rtcore
from hand_service.firmware.hold import hold
from hand_service.firmware.rig import Rig
from hand_service.transports import HandshakeError, SensorSample
from hand_service.transports.link import LinkTransport
from hand_service.wire.messages import FaultKind

WAIT_S = 5.0  # generous: two cores shared with other engineers' test runs


def wait_for(predicate: Callable[[], Any], timeout_s: float = WAIT_S) -> Any:
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        value = predicate()
        if value:
            return value
        time.sleep(0.005)
    return predicate()


@contextmanager
def holding(transport: LinkTransport, pressure_kpa: float = 30.0) -> Iterator[threading.Event]:
    """A host thread answering every sample with a setpoint, so the watchdog stays fed."""
    stop = threading.Event()
    thread = threading.Thread(target=hold, args=(transport, pressure_kpa, stop), daemon=True)
    thread.start()
    try:
        yield stop
    finally:
        stop.set()
        thread.join(timeout=5)


@dataclass(frozen=True)
class FaultCase:
    kind: FaultKind
    finger_index: int
    duration_ms: int
    value: int
    detected: Callable[[dict[str, int]], int]  # the counter that must grow
    log_line: str


def counters(transport: LinkTransport) -> dict[str, int]:
    return transport.health().as_dict()


FAULTS = [
    FaultCase(FaultKind.DROP, 255, 600, 30, lambda h: h["sequence_gaps"], r"sensor sequence gap"),
    FaultCase(FaultKind.DELAY, 255, 300, 250, lambda h: h["late_samples"], r"no sensor sample for \d+ ms"),
    FaultCase(FaultKind.CORRUPT, 255, 600, 30, lambda h: h["crc_errors"], r"failed their CRC"),
    FaultCase(FaultKind.STUCK_SENSOR, 1, 800, 0, lambda h: h["stuck_sensor"],
              r"finger index: sensor stuck at"),
    FaultCase(FaultKind.SENSOR_OUT_OF_RANGE, 2, 300, 0, lambda h: h["sensor_out_of_range"],
              r"finger middle: sensor reads \d+\.\d mV, outside the board's range"),
    FaultCase(FaultKind.SILENCE, 255, 1200, 0, lambda h: h["timeouts"] and h["reconnects"],
              r"reconnected to firmware"),
    FaultCase(FaultKind.REBOOT, 255, 0, 300, lambda h: h["firmware_reboots"], r"firmware rebooted"),
]


class TestValveBoard:
    def test_handshake_reports_the_firmware(self, rig: Rig) -> None:
        rig.start_mock(firmware_version="1.4.2")
        transport = rig.transport()
        status = transport.open()
        assert (status.protocol_version, status.firmware_version) == (1, "1.4.2")
        sample = wait_for(transport.latest)
        assert isinstance(sample, SensorSample)
        assert sample.sensor_mv.shape == sample.pressure_meas_kpa.shape == (5,)
        # the untouched hand rests near 0 deg: mV = (0 - offset) / gain
        angles = [f.sensor_gain_deg_per_mv * mv + f.sensor_offset_deg
                  for f, mv in zip(rig.profile.fingers, sample.sensor_mv, strict=True)]
        assert np.all(np.abs(angles) < 3.0)

    def test_wrong_protocol_version_is_refused(self, rig: Rig) -> None:
        rig.start_mock(protocol_version=2)
        with pytest.raises(HandshakeError, match=r"speaks protocol 2, but profile '.+' needs protocol 1"):
            rig.transport().open()

    def test_silent_port_is_refused_clearly(self, rig: Rig) -> None:
        transport = rig.transport(handshake_timeout_ms=200)  # no mock started
        with pytest.raises(HandshakeError, match=r"cannot open|no answer from the firmware"):
            transport.open()

    def test_closed_loop_step_to_a_target_angle(self, rig: Rig) -> None:
        """The C control step, driven through the bus at the firmware's pace, reaches 45 deg."""
        rig.start_mock()
        transport = rig.transport()
        transport.open()
        hand = rtcore.Hand(rig.profile.hand_config())
        hand.inputs.mode[:] = rtcore.MODE_POSITION
        hand.inputs.angle_ref_deg[:] = 45.0
        angles = []
        end = time.monotonic() + 2.5
        while time.monotonic() < end:
            sample = transport.latest()
            if sample is None:
                time.sleep(0.001)
                continue
            hand.inputs.sensor_mv[:] = sample.sensor_mv
            hand.step()
            transport.send(hand.outputs.pressure_cmd_kpa)
            angles.append(hand.outputs.angle_deg.copy())
        settled = np.array(angles[-50:])  # the last 0.5 s
        assert len(angles) > 150, f"only {len(angles)} samples in 2.5 s"
        np.testing.assert_allclose(settled.mean(axis=0), 45.0, atol=2.0)
        assert transport.health().sequence_gaps < 5

    @pytest.mark.parametrize("case", FAULTS, ids=[c.kind.name.lower() for c in FAULTS])
    def test_injected_fault_is_detected(self, rig: Rig, case: FaultCase,
                                        caplog: pytest.LogCaptureFixture) -> None:
        caplog.set_level(logging.INFO, logger="hand_service.transports")
        rig.start_mock()
        transport = rig.transport()
        transport.open()
        with holding(transport):
            assert wait_for(lambda: transport.health().frames_in > 100)
            before = case.detected(counters(transport))
            transport.inject_fault(case.kind, case.finger_index, case.duration_ms, case.value)
            assert wait_for(lambda: case.detected(counters(transport)) > before, 8.0), counters(transport)
            host_lines = [r.getMessage() for r in caplog.records if r.name == "hand_service.transports"]
            assert any(re.search(case.log_line, line) for line in host_lines), host_lines
            # the fault over, the link is whole again: fresh samples flow
            time.sleep(case.duration_ms / 1e3)
            transport.latest()
            assert wait_for(transport.latest), f"no sample after the {case.kind.name} fault"

    def test_firmware_vents_when_the_host_dies(self, rig: Rig) -> None:
        """Safety: the host stops without a word (SIGKILL), the firmware's watchdog vents."""
        rig.start_mock()
        watchdog_s = rig.profile.safety["firmware_watchdog_ms"] / 1e3
        if rig.in_process:  # the virtual bus lives in this process: the host "dies" by going silent
            transport = rig.transport()
            transport.open()
            with holding(transport, 60.0):
                wait_for(lambda: transport.health().frames_out > 100)
            transport.close()
            killed_s = time.monotonic()
        else:
            host = rig.start_host(60.0)
            time.sleep(0.5)
            assert host.poll() is None
            assert not rig.vent_times_s(), "the firmware vented while the host was alive"
            killed_s = time.monotonic()
            os.kill(host.pid, signal.SIGKILL)
            host.wait(timeout=5)
        vents = wait_for(lambda: [t for t in rig.vent_times_s() if t > killed_s - watchdog_s], 10 * watchdog_s)
        assert vents, "the firmware did not vent within ten watchdog times"
        assert vents[0] - killed_s < 10 * watchdog_s
        # a new host finds the valves vented: the chambers empty
        transport = rig.transport()
        assert transport.open().vented
        time.sleep(0.3)
        sample = wait_for(transport.latest)
        assert np.all(sample.pressure_meas_kpa < 5.0), sample.pressure_meas_kpa
