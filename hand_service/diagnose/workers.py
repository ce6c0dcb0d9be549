"""How many threads diagnose's own pools use: the Jacobian's columns
(fitting/output_error.py), the effects screened and fitted at once and an effect's starts
(search/forward_selection.py, outside_library/). The simulator runs without Python's lock,
so on a machine with several cores these threads share the work; every result is the same,
bit for bit, whatever their number (each simulation has its own C state and arrays, and the
results are taken in order).

HAND_DIAGNOSE_THREADS=1 in the environment makes diagnose run in one thread; any other
whole number caps the threads. It is read once, when diagnose is imported."""

from __future__ import annotations

import os
from collections.abc import Mapping

THREADS_ENV = "HAND_DIAGNOSE_THREADS"
MOST_THREADS = 4  # beyond this a Jacobian (3 to 6 columns) has nothing left to share


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
