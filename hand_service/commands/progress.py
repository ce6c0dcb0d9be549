"""What a long command says while it works, on stderr, through one library (tqdm).

    with Progress("trials", total=10, quiet=args.quiet) as progress:
        for ...:
            progress.advance(message="index_release_03.csv")
        progress.say("writing the plots")   # a stage; progress("...") does the same

- stderr a terminal: a tqdm bar (a count with a total, else the time since the start) with
  the latest message after it, redrawn in place; gone when done.
- stderr not a terminal (a log file, a pipe, CI): plain lines, `<label>: [  12.3 s] 3/10
  message`, the first at once and then at most one every LINE_EVERY_S, never a `\\r`.
- quiet: nothing.

`done()` prints the last line, `<label>: done in N s`, with N the wall time since the
process started (interpreter start-up and imports included: what a user timed), unless
quiet. `Progress.lines_on(stream)` tells which of the two a stream gets.
"""

from __future__ import annotations

import os
import sys
import time
from dataclasses import dataclass, field
from typing import Any, TextIO

LINE_EVERY_S = 2.0  # not a terminal: a line at most this often, so a log stays short
_IMPORTED_S = time.monotonic()


def wall_time_s() -> float:
    """Seconds since this process started (Linux: /proc/self/stat against /proc/uptime);
    elsewhere, since this module was imported."""
    try:
        with open("/proc/self/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        with open("/proc/uptime") as f:
            uptime_s = float(f.read().split()[0])
        started_s = int(fields[19]) / os.sysconf("SC_CLK_TCK")  # starttime, field 22
        return max(0.0, uptime_s - started_s)
    except (OSError, ValueError, IndexError):
        return time.monotonic() - _IMPORTED_S


@dataclass
class Progress:
    """Progress of one long command on `stream` (stderr): a bar on a terminal, plain
    periodic lines elsewhere, nothing when quiet."""

    label: str
    total: int | None = None
    quiet: bool = False
    stream: TextIO | None = None
    every_s: float = LINE_EVERY_S
    count: int = 0
    message: str = ""
    _started_s: float = field(default_factory=time.monotonic)
    _last_line_s: float | None = None
    _bar: Any = None

    def __post_init__(self) -> None:
        if self.stream is None:
            self.stream = sys.stderr
        if not self.quiet and self.lines_on(self.stream) == "bar":
            from tqdm import tqdm

            fmt = (None if self.total is not None
                   else "{desc}: {elapsed} {postfix}")  # no total: no bar to fill, the time
            self._bar = tqdm(total=self.total, desc=self.label, file=self.stream, leave=False,
                             dynamic_ncols=True, bar_format=fmt, mininterval=0.2)

    @staticmethod
    def lines_on(stream: TextIO) -> str:
        """"bar" on a terminal, else "lines"."""
        isatty = getattr(stream, "isatty", None)
        try:
            return "bar" if isatty is not None and isatty() else "lines"
        except ValueError:  # a closed stream
            return "lines"

    @property
    def elapsed_s(self) -> float:
        return time.monotonic() - self._started_s

    def say(self, message: str) -> None:
        """A new stage, not counted."""
        self._show(message, 0)

    __call__ = say

    def advance(self, steps: int = 1, message: str | None = None) -> None:
        """`steps` more of `total` done, with what was just done or is next."""
        self._show(self.message if message is None else message, steps)

    def _show(self, message: str, steps: int) -> None:
        self.count += steps
        self.message = message
        if self.quiet:
            return
        if self._bar is not None:
            self._bar.set_postfix_str(message, refresh=False)
            self._bar.update(steps) if steps else self._bar.refresh()
            return
        now = time.monotonic()
        if self._last_line_s is not None and now - self._last_line_s < self.every_s:
            return
        self._last_line_s = now
        count = f" {self.count}/{self.total}" if self.total is not None else ""
        self._line(f"[{self.elapsed_s:6.1f} s]{count} {message}".rstrip())

    def write(self, text: str, file: TextIO | None = None) -> None:
        """A line that is output, not progress (a result per case), to `file` (stdout by
        default): the bar is cleared and redrawn below it; printed even when quiet."""
        out = file if file is not None else sys.stdout
        if self._bar is not None:
            self._bar.write(text, file=out)
        else:
            print(text, file=out, flush=True)

    def _line(self, text: str) -> None:
        print(f"{self.label}: {text}", file=self.stream, flush=True)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def done(self, what: str = "done") -> float:
        """Close, and say `<label>: done in N s` (wall time of the process); returns N."""
        self.close()
        seconds = wall_time_s()
        if not self.quiet:
            self._line(f"{what} in {seconds:.1f} s")
        return seconds

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
