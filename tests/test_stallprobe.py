"""bench --machine: the bare loop on every CPU at once, stalls matched across CPUs."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np

from hand_service.bench.machine import match_stalls
from tests.test_cli import run_cli

PERIOD_NS = 1_000_000


def _loop(n: int, lates: dict[int, int]) -> tuple[np.ndarray, np.ndarray]:
    late = np.full(n, 50_000, dtype=np.int64)
    for k, v in lates.items():
        late[k] = v
    return late, np.arange(n, dtype=np.int64)


def test_stalls_that_overlap_in_time_are_one_whatever_the_cpu() -> None:
    cpu0 = _loop(1000, {100: 5_000_000, 500: 2_000_000, 900: 999_999})
    cpu1 = _loop(1000, {102: 3_000_000, 700: 1_500_000})
    stalls = match_stalls([cpu0[0], cpu1[0]], [cpu0[1], cpu1[1]], PERIOD_NS)
    assert [(s.t_s, s.late_ms, s.every_cpu) for s in stalls] == [
        (0.1, [5.0, 3.0], True),     # 100..105 ms and 102..105 ms: the machine stopped
        (0.5, [2.0, None], False),   # CPU 0 alone
        (0.7, [None, 1.5], False),   # CPU 1 alone; 999 us at 900 is under the threshold
    ]


def test_stalls_that_do_not_overlap_stay_apart() -> None:
    cpu0 = _loop(100, {10: 1_000_000})
    cpu1 = _loop(100, {12: 1_000_000})  # begins after CPU 0's ended (11 ms)
    stalls = match_stalls([cpu0[0], cpu1[0]], [cpu0[1], cpu1[1]], PERIOD_NS)
    assert [s.late_ms for s in stalls] == [[1.0, None], [None, 1.0]]


def test_bench_machine_runs_on_every_cpu_and_writes_its_keys(tmp_path: Path) -> None:
    out = tmp_path / "machine.json"
    result = run_cli("bench", "--machine", "--seconds", "1", "--no-realtime", "--json", str(out))
    assert result.returncode == 0, result.stderr
    figures = json.loads(out.read_text())
    assert figures["machine_cpus"] == sorted(os.sched_getaffinity(0))
    assert figures["machine_rate_hz"] == 1000 and figures["machine_realtime"] == ["normal scheduler"]
    n = len(figures["machine_cpus"])
    for key in ("machine_jitter_us_p50", "machine_jitter_us_p99", "machine_jitter_us_max"):
        assert len(figures[key]) == n and all(x >= 0 for x in figures[key])
    assert len(figures["machine_stalls"]) == (figures["machine_stalls_every_cpu"]
                                             + figures["machine_stalls_some_cpus"])
    assert "stalls of 1 ms or more" in result.stdout


def test_bench_machine_refuses_a_profile() -> None:
    result = run_cli("bench", "--machine", "--profile", "sim.yaml")
    assert result.returncode == 2 and "--machine checks the machine alone" in result.stderr
    assert "Traceback" not in result.stderr


def test_a_worker_that_fails_ends_the_probe_with_one_error_and_no_process_left() -> None:
    import multiprocessing

    import pytest

    from hand_service.bench.machine import probe
    from hand_service.errors import UserError

    with pytest.raises(UserError, match="the stall probe on CPU 99999 cannot run there"):
        probe(0.2, 1000.0, None, cpus=[min(os.sched_getaffinity(0)), 99999])  # no CPU 99999
    assert multiprocessing.active_children() == []
