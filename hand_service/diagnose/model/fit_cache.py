"""The fits a recording keeps: diagnose asks the same fit more than once, and a fit is a
deterministic function of what it minimises (the misfit on the fitting samples and the
prior), its parameters, start and base finger, so it is found again, bit for bit.

The search at the noise filter's order at rest (search/rest_order.py) is the largest
case: the noise model's order and coefficients score the fits (ΔBIC on the innovations)
but do not enter them (a fit minimises the misfit, the sensor's offset and drift taken
out), so the second search asks the first's fits again, set search and all. The least
recently used go first, past FIT_CACHE_BYTES (a fit keeps its angle and its Jacobian).
Thread-safe: the effects are fitted side by side."""

from __future__ import annotations

from collections.abc import Callable, Hashable
from typing import Any

from hand_service.diagnose.model.lru import ByteBudgetLru

FIT_CACHE_BYTES = 64 * 2**20  # the fits a recording keeps (FitCache)


class FitCache:
    """Fits by key. A key names the arrays the fit reads by identity (`anchors`): an entry
    is served only while the very same objects are asked again, so a reused id never
    matches, and the cache keeps those objects alive while it holds the entry."""

    def __init__(self, budget_bytes: int = FIT_CACHE_BYTES) -> None:
        self._fits: ByteBudgetLru[tuple[tuple[object, ...], Any]] = ByteBudgetLru(budget_bytes)

    def get(self, key: Hashable, anchors: tuple[object, ...]) -> Any | None:
        def same_anchors(entry: tuple[tuple[object, ...], Any]) -> bool:
            kept = entry[0]
            return len(kept) == len(anchors) and all(a is b for a, b in zip(kept, anchors, strict=True))

        entry = self._fits.get(key, same_anchors)
        return None if entry is None else entry[1]

    def put(self, key: Hashable, anchors: tuple[object, ...], value: Any, nbytes: int) -> None:
        self._fits.put(key, (anchors, value), nbytes)

    def get_or_fit(self, key: Hashable, anchors: tuple[object, ...], run: Callable[[], Any],
                   nbytes: Callable[[Any], int]) -> Any:
        """The cached value of `key`, else `run()`'s, kept (two threads asking at once both
        run it: the same result)."""
        found = self.get(key, anchors)
        if found is not None:
            return found
        value = run()
        self.put(key, anchors, value, nbytes(value))
        return value

    @property
    def hits(self) -> int:
        return self._fits.hits

    @property
    def misses(self) -> int:
        return self._fits.misses

    def __len__(self) -> int:
        return len(self._fits)
