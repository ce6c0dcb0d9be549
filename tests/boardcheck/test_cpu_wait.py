"""board-check's own wait for a CPU, read from the thread's scheduler statistics."""

from __future__ import annotations

from pathlib import Path

from hand_service.boardcheck.cpu_wait import CpuWait


def test_the_run_queue_field_is_read_in_seconds(tmp_path: Path) -> None:
    stat = tmp_path / "schedstat"
    stat.write_text("309251 10884928 2\n")  # ns on a CPU, ns waiting for one, timeslices
    cpu = CpuWait(stat)
    assert cpu.available and cpu.waited_s() == 0.010884928
    stat.write_text("409251 52884928 3\n")
    assert cpu.waited_s() == 0.052884928
    cpu.close()
    assert not cpu.available and cpu.waited_s() is None


def test_no_statistics_is_not_a_wait(tmp_path: Path) -> None:
    cpu = CpuWait(tmp_path / "missing")
    assert not cpu.available and cpu.waited_s() is None
