"""A pool of threads whose waiting callers help: diagnose's one pool (workers.py).

A map offers its items to the pool's queue; the calling thread runs the first item, then
takes each of its items in order: one nobody has started it runs itself; one already
running it waits for, running meanwhile whatever item (any map's) is still queued. So the
threads running items are the pool's and the callers', never more, however deeply maps
nest (a round's effects, each effect's starts, each start's Jacobian columns), and no core
sits idle while an item is queued. A thread waits only for an item already running, whose
own waits are for the items it offered: fork-join, so the waits cannot form a cycle.
"""

from __future__ import annotations

import threading
from collections import deque
from collections.abc import Callable, Sequence
from typing import Generic, TypeVar

T = TypeVar("T")
R = TypeVar("R")

_QUEUED, _RUNNING, _DONE = range(3)


class _Item(Generic[T, R]):
    __slots__ = ("argument", "error", "function", "result", "state")

    def __init__(self, function: Callable[[T], R], argument: T) -> None:
        self.function, self.argument = function, argument
        self.state = _QUEUED
        self.result: R | None = None
        self.error: BaseException | None = None


class HelpingPool:
    """`size` threads and a queue of items; `map` runs items on them and on its caller."""

    def __init__(self, size: int, name: str) -> None:
        self._queue: deque[_Item] = deque()
        self._changed = threading.Condition()
        self._stopping = False
        self.size = size
        self._threads = [threading.Thread(target=self._work, name=f"{name}_{i}", daemon=True)
                         for i in range(size)]
        for thread in self._threads:
            thread.start()

    def _claim(self) -> _Item | None:
        """The oldest queued item, now running (the caller holds the lock)."""
        while self._queue:
            item = self._queue.popleft()
            if item.state == _QUEUED:
                item.state = _RUNNING
                return item
        return None

    def _run(self, item: _Item) -> None:
        try:
            item.result = item.function(item.argument)
        except BaseException as error:  # handed to the map that offered it
            item.error = error
        with self._changed:
            item.state = _DONE
            self._changed.notify_all()

    def _work(self) -> None:
        while True:
            with self._changed:
                item = self._claim()
                while item is None and not self._stopping:
                    self._changed.wait()
                    item = self._claim()
                if item is None:
                    return
            self._run(item)

    def _await(self, item: _Item[T, R]) -> R:
        """Item's result: run by this thread if nobody has started it, else awaited while this
        thread runs whatever is queued."""
        while True:
            with self._changed:
                if item.state == _QUEUED:
                    item.state = _RUNNING
                    other: _Item | None = item
                else:
                    other = None
                    while item.state != _DONE and (other := self._claim()) is None:
                        self._changed.wait()
            if other is not None:
                self._run(other)
            if item.state == _DONE:
                if item.error is not None:
                    raise item.error
                return item.result  # type: ignore[return-value]

    def map(self, function: Callable[[T], R], arguments: Sequence[T]) -> list[R]:
        """[function(a) for a in arguments], the first in the calling thread, in order."""
        offered = [_Item(function, a) for a in arguments[1:]]
        with self._changed:
            self._queue.extend(offered)
            self._changed.notify_all()
        try:
            results = [function(arguments[0])]
            results.extend(self._await(item) for item in offered)
        finally:  # an item raised: those not started are dropped
            with self._changed:
                for item in offered:
                    if item.state == _QUEUED:
                        item.state = _DONE
        return results

    def shutdown(self, wait: bool = True) -> None:
        """Stop the threads once the queue is empty (their running items finish first);
        `wait`: until they have."""
        with self._changed:
            self._stopping = True
            self._changed.notify_all()
        for thread in self._threads if wait else ():
            thread.join()
