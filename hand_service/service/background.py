"""Work too long for the loop's slack (parsing an hour of trajectory), run in a worker
thread; the loop's thread polls `done` in its slack and takes the result there, so the
supervisor's state is only ever touched between ticks."""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any, Generic, TypeVar

T = TypeVar("T")


class Background(Generic[T]):
    """fn(*args) in a daemon thread of its own."""

    def __init__(self, fn: Callable[..., T], *args: Any, name: str = "background") -> None:
        self._result: T | None = None
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, args=(fn, *args), name=name, daemon=True)
        self._thread.start()

    def _run(self, fn: Callable[..., T], *args: Any) -> None:
        try:
            self._result = fn(*args)
        except BaseException as exc:  # handed to the loop's thread by result()
            self._error = exc

    @property
    def done(self) -> bool:
        return not self._thread.is_alive()

    def result(self) -> T:
        """The value, or the exception fn raised (call once done)."""
        if self._error is not None:
            raise self._error
        return self._result  # type: ignore[return-value]
