"""`run`'s status line: one terminal line rewritten in place, ended before any log line.

The line is written with a carriage return and no newline, so a log record printed while
it shows would continue it ("... faults 0WARNING ..."). While the line is active a filter
on the root logger's handlers ends it first; the next status rewrite starts a new one.
"""

from __future__ import annotations

import logging
import threading
from typing import TextIO


class StatusLine:
    """The line, rewritten by `show` and ended (a newline) by `end`, from any thread."""

    def __init__(self, out: TextIO) -> None:
        self.out = out
        self.shown = False
        self._lock = threading.Lock()

    def show(self, text: str) -> None:
        with self._lock:
            self.out.write("\r" + text + "\x1b[K")
            self.out.flush()
            self.shown = True

    def end(self) -> None:
        with self._lock:
            if self.shown:
                self.out.write("\n")
                self.out.flush()
                self.shown = False


class EndBeforeLog(logging.Filter):
    """A handler filter that ends the status line before the record is written."""

    def __init__(self, line: StatusLine) -> None:
        super().__init__()
        self.line = line

    def filter(self, record: logging.LogRecord) -> bool:
        self.line.end()
        return True

    def attach(self) -> None:
        for handler in logging.getLogger().handlers:
            handler.addFilter(self)

    def detach(self) -> None:
        for handler in logging.getLogger().handlers:
            handler.removeFilter(self)
