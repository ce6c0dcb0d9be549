"""The transports' sample monitor, fed reports at chosen host times: what counts as a late
sample and a sequence gap across a reconnect, a reboot and a new open()."""

from __future__ import annotations

import logging

import pytest

from hand_service.config.profile import load_profile
from hand_service.transports.base import TransportHealth
from hand_service.transports.monitor import SampleMonitor
from hand_service.transports.serial_transport import SerialTransport
from hand_service.wire.messages import SensorReport

STALE_S = 0.05


def report(sequence: int) -> SensorReport:
    return SensorReport(sequence % 256, 0, [1000.0 + sequence % 7] * 5, [0.0] * 5)


@pytest.fixture
def monitor() -> SampleMonitor:
    profile = load_profile(None)
    settings = {"sensor_min_mv": 0.0, "sensor_max_mv": 5000.0, "stuck_samples": 0}
    return SampleMonitor(profile.finger_names, settings, STALE_S, TransportHealth())


def test_on_time_samples_are_neither_late_nor_lost(monitor: SampleMonitor) -> None:
    for i in range(100):
        assert monitor.sample(report(i), 0.01 * i, 0) is not None
    assert monitor.health.extra["late_samples"] == 0 and monitor.health.sequence_gaps == 0


def test_a_wait_that_ends_in_a_reconnect_is_still_a_late_sample(
        monitor: SampleMonitor, caplog: pytest.LogCaptureFixture) -> None:
    """A board held silent past the transport timeout: the host reconnects (restart), and
    the first sample after it ends a wait of 600 ms."""
    caplog.set_level(logging.WARNING, logger="hand_service.transports")
    monitor.sample(report(10), 0.0, 0)
    monitor.restart()
    sample = monitor.sample(report(80), 0.6, 0)
    assert sample is not None and sample.sequence == 1  # no gap is counted across a restart
    assert monitor.health.extra["late_samples"] == 1 and monitor.health.sequence_gaps == 0
    assert any("no sensor sample for 600 ms" in r.getMessage() for r in caplog.records)


def test_a_new_open_forgets_the_last_sample(monitor: SampleMonitor) -> None:
    monitor.sample(report(10), 0.0, 0)
    monitor.begin()
    monitor.sample(report(11), 5.0, 0)
    assert monitor.health.extra["late_samples"] == 0


def test_a_gap_is_the_run_of_samples_lost_before_a_sample(monitor: SampleMonitor) -> None:
    assert monitor.sample(report(10), 0.0, 0).lost_in_a_row == 0  # type: ignore[union-attr]
    assert monitor.sample(report(17), 0.07, 0).lost_in_a_row == 6  # type: ignore[union-attr]
    assert monitor.sample(report(18), 0.08, 0).lost_in_a_row == 0  # type: ignore[union-attr]
    monitor.restart()  # nothing is lost across a reconnect or a reboot: the stream starts over
    assert monitor.sample(report(40), 0.09, 0).lost_in_a_row == 0  # type: ignore[union-attr]


def test_samples_replaced_before_the_tick_took_them_were_not_lost() -> None:
    """A host that ticks late finds the newest sample of several: those it skipped did
    arrive, and only the runs that never did count (the longest of them)."""
    transport = SerialTransport(load_profile("serial-v1.yaml"), port="/nonexistent/tty")
    transport._phase = "running"  # fed by hand: no port, no threads
    for sequence in (1, 2, 3, 7, 8, 9, 11, 12):  # 3 lost after 3, 1 after 9
        transport._handle(report(sequence), 0.0)
    sample = transport.latest()
    assert sample is not None and sample.sequence == 11  # the firmware's count from its first: 12 - 1
    assert sample.lost_in_a_row == 3
    for sequence in range(13, 40):  # 27 samples the tick never took, none lost
        transport._handle(report(sequence), 0.0)
    sample = transport.latest()
    assert sample is not None and sample.lost_in_a_row == 0
