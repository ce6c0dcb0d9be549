"""The refused-token warning, at most one line per interval: any local user may try the
TCP port as fast as it likes, and the log must not fill with its attempts. The first
refusal is logged at once; those within the interval after it are counted, and said in
the next line."""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

INTERVAL_S = 10.0


@dataclass
class RefusalLog:
    log: logging.Logger
    interval_s: float = INTERVAL_S
    _last_s: float | None = None
    held: int = 0  # refusals not logged since the last line

    def refused(self, client: str, now_s: float | None = None) -> None:
        now_s = time.monotonic() if now_s is None else now_s
        if self._last_s is not None and now_s - self._last_s < self.interval_s:
            self.held += 1
            return
        more = (f" ({self.held} more refused in the {self.interval_s:g} s before, not logged)"
                if self.held else "")
        self.log.warning("refused %s: no valid token in its first request%s", client, more)
        self._last_s, self.held = now_s, 0
