"""The absolute schedule in C: deadlines never drift, a miss skips ahead, the sleep never
returns early, the bare floor loop reports what it measured, and memory locking locks."""

from __future__ import annotations

import errno
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from rtcore import clock


def test_deadlines_are_absolute_whatever_a_tick_costs() -> None:
    s = clock.Schedule(period_ns=1_000_000, start_ns=5_000_000_000)
    ends = [5_000_000_000 + 300_000, 5_001_000_000 + 900_000, 5_002_000_000 + 10]
    for k, end in enumerate(ends):
        assert s.deadline_ns == 5_000_000_000 + k * 1_000_000
        assert s.advance(end) == 0
    assert s.deadline_ns == 5_003_000_000


def test_a_miss_skips_to_the_next_deadline_ahead() -> None:
    s = clock.Schedule(period_ns=1_000_000, start_ns=0)
    assert s.advance(3_500_000) == 3  # tick 0 ended after deadlines 1, 2 and 3: all skipped
    assert s.index == 4 and s.deadline_ns == 4_000_000
    assert s.advance(4_000_000) == 0  # ending exactly on deadline 5 is not a skip
    assert s.index == 5


def test_sleep_never_returns_before_its_deadline() -> None:
    for spin_ns in (0, 200_000):
        for _ in range(20):
            deadline = clock.now_ns() + 300_000
            woke = clock.sleep_until_ns(deadline, spin_ns)
            assert woke >= deadline
            assert clock.now_ns() >= deadline


def test_floor_loop_follows_the_schedule() -> None:
    s = clock.Schedule(period_ns=2_000_000)
    first = s.index
    run = clock.floor_loop(s, 25)
    assert run.wake_late_ns.shape == (25,)
    assert np.all(run.wake_late_ns >= 0)
    assert np.all(np.diff(run.index) >= 1) and run.index[0] == first
    assert s.index > run.index[-1]
    assert run.misses == int(np.sum(run.wake_late_ns > s.period_ns))


def _locked_kib() -> int:
    """VmLck of this process: the memory mlockall has locked, in KiB."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmLck:"):
            return int(line.split()[1])
    raise AssertionError("no VmLck in /proc/self/status")


def test_memory_locking_locks_or_says_why_not() -> None:
    """lock_memory() either really locks the process's memory (0) or returns mlockall's
    errno (not permitted, over the memlock limit) and locks nothing; unlock undoes it."""
    assert _locked_kib() == 0
    code = clock.lock_memory()
    try:
        if code == 0:
            assert _locked_kib() > 1024  # the interpreter and numpy, at least
        else:
            assert code in (errno.EPERM, errno.ENOMEM, errno.EAGAIN), os.strerror(code)
            assert _locked_kib() == 0
    finally:
        unlocked = clock.unlock_memory()
    assert unlocked == 0
    assert _locked_kib() == 0


REFUSED = """
import ctypes, errno, resource
from rtcore import clock
resource.setrlimit(resource.RLIMIT_MEMLOCK, (0, resource.getrlimit(resource.RLIMIT_MEMLOCK)[1]))
# without CAP_IPC_LOCK in the effective set (root has it), the memlock limit of 0 holds
libc = ctypes.CDLL(None, use_errno=True)
header = (ctypes.c_uint32 * 2)(0x20080522, 0)  # _LINUX_CAPABILITY_VERSION_3, this process
data = (ctypes.c_uint32 * 6)()  # two {effective, permitted, inheritable}
assert libc.capget(header, data) == 0, errno.errorcode[ctypes.get_errno()]
data[0] &= ~(1 << 14)  # CAP_IPC_LOCK
assert libc.capset(header, data) == 0, errno.errorcode[ctypes.get_errno()]
print(clock.lock_memory())
print(next(int(line.split()[1]) for line in open("/proc/self/status") if line.startswith("VmLck:")))
"""


def test_memory_locking_refused_names_the_errno() -> None:
    """Where mlockall is not permitted (no CAP_IPC_LOCK, a memlock limit of 0), lock_memory
    returns its errno, which the daemon reports, and nothing is locked."""
    ran = subprocess.run([sys.executable, "-c", REFUSED], capture_output=True, text=True, timeout=60)
    assert ran.returncode == 0, ran.stderr
    code, locked_kib = map(int, ran.stdout.split())
    assert code in (errno.EPERM, errno.ENOMEM), code
    assert locked_kib == 0
