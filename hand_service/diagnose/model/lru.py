"""A least-recently-used store held to a budget in bytes, thread-safe: what the recording's
simulation and fit caches (simulation_cache.py, fit_cache.py) have in common."""

from __future__ import annotations

import threading
from collections import OrderedDict
from collections.abc import Callable, Hashable
from typing import Generic, TypeVar

V = TypeVar("V")


class ByteBudgetLru(Generic[V]):
    """Values by key, each with its size in bytes; past budget_bytes the least recently used
    go first, and a value larger than the budget is not kept. Counts hits and misses."""

    def __init__(self, budget_bytes: int) -> None:
        self._items: OrderedDict[Hashable, tuple[V, int]] = OrderedDict()
        self._lock = threading.Lock()
        self._bytes = 0
        self.budget_bytes = budget_bytes
        self.hits = 0
        self.misses = 0

    def get(self, key: Hashable, accept: Callable[[V], bool] | None = None) -> V | None:
        """The value of `key` (None if absent, or if `accept` refuses it: a miss either way)."""
        with self._lock:
            entry = self._items.get(key)
            if entry is None or (accept is not None and not accept(entry[0])):
                self.misses += 1
                return None
            self._items.move_to_end(key)
            self.hits += 1
            return entry[0]

    def put(self, key: Hashable, value: V, nbytes: int) -> None:
        """Keep `value` under `key` unless the key is kept already or it exceeds the budget."""
        with self._lock:
            if key in self._items or nbytes > self.budget_bytes:
                return
            self._items[key] = (value, nbytes)
            self._bytes += nbytes
            while self._bytes > self.budget_bytes:
                _, (_, dropped) = self._items.popitem(last=False)
                self._bytes -= dropped

    def __len__(self) -> int:
        return len(self._items)
