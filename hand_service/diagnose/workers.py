"""How many threads diagnose's work runs on, and the one pool they share: the Jacobian's
columns (fitting/output_error.py), the effects screened and fitted at once and an effect's
starts (search/forward_selection.py, outside_library/). The simulator runs without Python's
lock, so on a machine with several cores these threads share the work; every result is the
same, bit for bit, whatever their number (each simulation has its own C state and arrays,
and the results are taken in order).

Maps nest (a round's effects, each effect's starts, each start's Jacobian columns), and all
of them go through one process-wide pool of threads() − 1 threads, the calling thread
being the last (helping_pool.py: a caller that waits runs queued items meanwhile), so at
most threads() threads run diagnose's work at once however deep the nesting.

HAND_DIAGNOSE_THREADS=1 in the environment makes diagnose run in one thread; any other
whole number caps the threads. It is read once, when diagnose is imported; `using(jobs)`
(`hand-service diagnose --jobs N`) sets the number for one diagnosis. The number is the
process's: two diagnoses running at once in one process share it."""

from __future__ import annotations

import os
import threading
from collections.abc import Callable, Iterable, Iterator, Mapping
from contextlib import contextmanager
from typing import TypeVar

from hand_service.diagnose.helping_pool import HelpingPool

THREADS_ENV = "HAND_DIAGNOSE_THREADS"
MOST_THREADS = 4  # beyond this a Jacobian (3 to 6 columns) has nothing left to share
T = TypeVar("T")
R = TypeVar("R")


def thread_count(environ: Mapping[str, str] | None = None) -> int:
    """The threads diagnose's pools may use: one per core, at most MOST_THREADS, fewer (or
    one, serial) when THREADS_ENV says so."""
    env = os.environ if environ is None else environ
    cores = os.cpu_count() or 1
    asked = env.get(THREADS_ENV, "").strip()
    if not asked:
        return max(1, min(MOST_THREADS, cores))
    if not asked.isdigit() or int(asked) < 1:
        raise ValueError(f"{THREADS_ENV}={asked!r}: a whole number of threads, 1 or more (1: one thread)")
    return min(MOST_THREADS, int(asked))


_threads = thread_count()


def threads() -> int:
    """The threads diagnose's pools use now (1: every pool runs in the calling thread)."""
    return _threads


@contextmanager
def using(jobs: int | None) -> Iterator[int]:
    """Diagnose's pools on `jobs` threads (at most MOST_THREADS) within the block; None
    leaves the number as it is. Yields the number in force."""
    global _threads
    if jobs is None:
        yield _threads
        return
    if jobs < 1:
        raise ValueError(f"jobs={jobs}: a whole number of threads, 1 or more (1: one thread)")
    saved, _threads = _threads, min(MOST_THREADS, jobs)
    try:
        yield _threads
    finally:
        _threads = saved


_pool: HelpingPool | None = None  # threads() − 1 threads, made when first asked
_pool_lock = threading.Lock()


def _shared_pool(size: int) -> HelpingPool:
    """The process's pool of `size` threads; one of another size is replaced, its threads
    left to finish what is queued and stop (not awaited here: its items' callers may be
    waiting for this lock)."""
    global _pool
    with _pool_lock:
        if _pool is None or _pool.size != size:
            if _pool is not None:
                _pool.shutdown(wait=False)
            _pool = HelpingPool(size, "diagnose")
        return _pool


def shutdown() -> None:
    """Stop the shared pool's threads (after their running items); the next map makes a new one."""
    global _pool
    with _pool_lock:
        if _pool is not None:
            _pool.shutdown()
        _pool = None


def ordered_map(function: Callable[[T], R], items: Iterable[T]) -> list[R]:
    """[function(item) for item in items], on up to threads() threads at once (each item its
    own simulations), the results in the items' order whatever finishes first: the first
    item in the calling thread, the others offered to the shared pool (helping_pool.py);
    all in the calling thread when one thread is asked or there is one item."""
    items = list(items)
    if _threads < 2 or len(items) < 2:
        return [function(item) for item in items]
    return _shared_pool(_threads - 1).map(function, items)
