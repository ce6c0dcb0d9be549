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
from pathlib import Path
from typing import Any

import can
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hand_service.firmware.hold import hold
from hand_service.firmware.rig import Rig
from hand_service.transports import HandshakeError, SensorSample
from hand_service.transports.link import LinkTransport
from hand_service.wire.messages import FaultKind, SensorReport
from tests.hil.closed_loop import step_to_angle

WAIT_S = 5.0  # generous: two cores shared with other engineers' test runs
ATTEMPTS = 5  # closed-loop runs on fresh rigs before a machine that stalls in all is skipped


def _fresh(rig: Rig, workdir: Path) -> Rig:
    """Another rig like `rig` (its class, link and firmware) on channels of its own."""
    workdir.mkdir()
    again = type(rig)(rig.name, workdir, rig.profile)
    if hasattr(rig, "binary"):
        again.binary = rig.binary  # the board's host build (tests/board)
    return again


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


def host_lines(caplog: pytest.LogCaptureFixture) -> list[str]:
    return [r.getMessage() for r in list(caplog.records) if r.name == "hand_service.transports"]


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
    FaultCase(FaultKind.FIRMWARE_FAULT, 255, 300, 1, lambda h: h["firmware_faults"],
              r"firmware reports fault 1 \(valve_driver\): it vented every valve"),
]


# -- garbage on the wire ------------------------------------------------------------------

def _flip(data: bytes, where: int, bit: int) -> bytes:
    out = bytearray(data)
    out[where % len(out)] ^= 1 << bit
    return bytes(out)


def _slcan_line(frame: can.Message) -> bytes:
    return f"t{frame.arbitration_id:03X}{frame.dlc}{bytes(frame.data).hex().upper()}\r".encode()


class WireFeeder:
    """The host's decoding path for one rig, fed directly: garbage, then good frames."""

    def __init__(self, rig: Rig) -> None:
        self.rig = rig
        options = {"channel": "loop://"} if rig.name == "slcan" else {}
        self.transport = rig.transport(**options)
        self.codec = self.transport.codec
        if rig.name == "slcan":  # python-can's own slcan parser, on pyserial's loopback port
            self.transport.link.connect()
            self.port = self.transport.link.bus.serialPortOrig  # type: ignore[attr-defined]
            self.port.timeout = 0  # read what is there, never wait: 10,000 inputs must be quick
        self.sequence = 0
        self._encoded: dict[int, list[Any]] = {}

    def reports(self) -> list[SensorReport]:
        out = []
        for _ in range(2):
            self.sequence = (self.sequence + 1) % 256
            out.append(SensorReport(self.sequence, 0, [100.0 + self.sequence + i for i in range(5)],
                                    [float(i) for i in range(5)]))
        return out

    def garbage(self, raw: bytes) -> Any:
        """Rubbish read out of random bytes: random frames or chunks, and good frames with one
        bit flipped (bad CRCs). One cheap draw of bytes lets hypothesis try 10,000 inputs fast."""
        good = self.encode(SensorReport(7, 0, [500.0] * 5, [10.0] * 5))
        ids = (0x110, 0x120, 0x130, 0x140, 0x141, 0x7E0, 0x7FF, 0x000)
        units: list[Any] = []
        i = 0
        while i + 2 < len(raw):
            head, a, b = raw[i], raw[i + 1], raw[i + 2]
            if head < 64:  # a good frame, one bit flipped
                frame = good[head % len(good)]
                if self.rig.name == "virtual":
                    units.append(can.Message(arbitration_id=frame.arbitration_id,
                                             data=_flip(bytes(frame.data), a, b % 8)))
                else:
                    units.append(_flip(_slcan_line(frame) if self.rig.name == "slcan" else frame, a, b % 8))
                i += 3
            elif self.rig.name == "virtual":  # a frame with a random id and payload
                data = raw[i + 2:i + 2 + a % 9]
                units.append(can.Message(arbitration_id=ids[head % len(ids)], data=data))
                i += 2 + len(data)
            else:  # raw bytes
                units.append(raw[i + 1:i + 1 + head % 24])
                i += 1 + head % 24
        return units if self.rig.name == "virtual" else b"".join(units)

    def encode(self, report: SensorReport) -> list[Any]:
        if self.rig.name == "serial":  # serial frames carry a running frame sequence
            return self.codec.encode(report)
        if report.sequence not in self._encoded:
            self._encoded[report.sequence] = self.codec.encode(report)
        return self._encoded[report.sequence]

    def feed(self, garbage: Any, reports: list[SensorReport]) -> list[Any]:
        frames = [f for r in reports for f in self.encode(r)]
        if self.rig.name == "virtual":
            return [m for f in [*garbage, *frames] for m in self.codec.decode(f)]
        if self.rig.name == "serial":
            return self.codec.decode(garbage + b"".join(frames))
        self.port.write(garbage + b"".join(_slcan_line(f) for f in frames))
        out: list[Any] = []
        while self.port.in_waiting:
            for frame in self.transport.link.read(0.0):
                out += self.codec.decode(frame)
        return out


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

    def test_closed_loop_step_to_a_target_angle(self, rig: Rig, tmp_path: Path) -> None:
        """The C control step, driven through the bus at the firmware's pace, reaches 45 deg.
        Only a run at that pace is judged (LoopRun.disturbance: CI twice saw a host stalled
        0.6 s by the shared machine, 93 and 232 samples skipped, end 4 deg short): a disturbed
        run is reported and repeated on a fresh rig, ATTEMPTS at most. A machine that stalls
        in every one of them (CI twice on 2026-11-27, waits of 0.1 to 2 s in all three runs
        of each, the same test passing alone at once) cannot run a loop at the firmware's
        pace at all: that is a skip, with what it saw, not a verdict on the control step."""
        disturbed = []
        for attempt in range(ATTEMPTS):
            bench = rig if attempt == 0 else _fresh(rig, tmp_path / f"again{attempt}")
            try:
                bench.start_mock()
                transport = bench.transport()
                transport.open()
                run = step_to_angle(transport, bench.profile)  # 2.5 s, 250 steps on fresh samples
                gaps = transport.health().sequence_gaps
            finally:
                if bench is not rig:
                    bench.close()
            reason = run.disturbance()
            if reason is not None:
                disturbed.append(reason)
                continue
            settled = run.angles_deg[-50:]  # the last 50 steps (0.5 s)
            np.testing.assert_allclose(settled.mean(axis=0), 45.0, atol=2.0, err_msg=run.summary())
            # nothing is lost on a pty: a host stalled long enough to overflow it times out first
            assert gaps < 5
            return
        pytest.skip(f"the machine kept the firmware's pace in none of {ATTEMPTS} runs: "
                    f"{'; '.join(disturbed)}")

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
            # the reader thread counts first and logs after: the line is an event of its own
            assert wait_for(lambda: any(re.search(case.log_line, line) for line in host_lines(caplog))), \
                host_lines(caplog)
            # the fault over (the firmware says so in its status), the link is whole again:
            # fresh samples flow
            assert wait_for(lambda: (status := transport.status()) is not None
                            and status.injected_fault == status.fault_code == 0,
                            case.duration_ms / 1e3 + WAIT_S), transport.status()
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
            killed_s = time.monotonic()
            os.kill(host.pid, signal.SIGKILL)
            host.wait(timeout=5)
        # the bound is on the firmware's own time stamp; its log line may take longer to come.
        # The vent after the kill is waited for: a host stalled by this shared machine past the
        # watchdog just before the kill makes a vent of its own, and once its commands resume
        # the board runs again (CI saw the new host find it running, the real vent not yet
        # come). Only if none comes after the kill does one in the watchdog before it count
        # (the host's last command may precede killed_s by that much, the board then vented).
        vents = wait_for(lambda: [t for t in rig.vent_times_s() if t > killed_s]) or \
            [t for t in rig.vent_times_s() if t > killed_s - watchdog_s]
        assert vents, "the firmware did not vent"
        assert vents[0] - killed_s < 10 * watchdog_s, "the firmware did not vent within ten watchdog times"
        # a new host finds the valves vented: the chambers empty
        transport = rig.transport()
        assert transport.open().vented
        samples: list[SensorSample] = []

        def chambers_empty() -> bool:
            sample = transport.latest()
            samples.extend([sample] if sample is not None else [])
            return bool(samples) and bool(np.all(samples[-1].pressure_meas_kpa < 5.0))

        assert wait_for(chambers_empty), samples[-1].pressure_meas_kpa if samples else "no sample"

    def test_garbage_never_crashes_the_decoder(self, rig: Rig) -> None:
        feeder = WireFeeder(rig)

        # 2 500 inputs per transport (up to 160 bytes each): every resynchronisation path
        # is reached many times over, in 6 s for all three instead of 25 (make test's budget);
        # over SLCAN 1 000: python-can's line parser costs 4 ms an input (10.5 s for 2 500,
        # a sixth of this file's time in make test), and the CAN codec behind it has the
        # virtual bus's 2 500
        examples = 1_000 if rig.name == "slcan" else 2_500

        @settings(max_examples=examples, deadline=None, derandomize=True,
                  suppress_health_check=list(HealthCheck))
        @given(raw=st.binary(max_size=160))
        def garbage_then_good_frames(raw: bytes) -> None:
            reports = feeder.reports()
            decoded = [m for m in feeder.feed(feeder.garbage(raw), reports) if isinstance(m, SensorReport)]
            assert decoded and decoded[-1] == reports[-1]  # resynchronised
            if rig.name == "serial":  # the serial decoder loses nothing that follows garbage
                assert decoded[-2:] == reports

        try:
            garbage_then_good_frames()
        finally:
            if rig.name == "slcan":
                feeder.transport.link.close()  # shut the loopback bus down
        stats = feeder.codec.stats
        assert stats.crc_errors + stats.decode_errors + stats.garbage_bytes > 0.4 * examples
