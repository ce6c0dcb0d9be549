"""The transports' sample monitor, fed reports at chosen host times: what counts as a late
sample and a sequence gap across a reconnect, a reboot and a new open()."""

from __future__ import annotations

import logging

import pytest

from hand_service.profile import load_profile
from hand_service.transports.base import TransportHealth
from hand_service.transports.monitor import SampleMonitor
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
