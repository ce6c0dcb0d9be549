"""The I/O benchmark runs end to end on every transport (figures reported, never asserted)."""

from __future__ import annotations

import pytest

from hand_service.bench.io import run_io_bench
from hand_service.firmware.rig import RIG_PROFILES


@pytest.mark.slow
def test_io_bench_reports_every_transport() -> None:
    results = run_io_bench(trials=2, commands=20, progress=False)
    for name in RIG_PROFILES:
        assert results[f"io_{name}_round_trip_ms_p50"] > 0
        assert results[f"io_{name}_vent_latency_ms_p50"] > 0
        assert results[f"io_{name}_vent_bound_ms"] == 110.0
