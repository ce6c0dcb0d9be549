"""The link's reader and writer threads run one real-time priority below the tick.

They are started during the handshake, after the supervisor took SCHED_FIFO, so they would
inherit the tick's own priority: at the same FIFO priority a tick that wakes while the
reader decodes a batch on its core waits until the reader blocks. One step below, the tick
preempts them at once, and they still run before every ordinary process on the machine.
"""

from __future__ import annotations

import os


def below_tick() -> None:
    """Lower the calling thread (Linux: the policy is per thread) one SCHED_FIFO priority,
    if it runs under SCHED_FIFO; otherwise leave it as it is."""
    try:
        if os.sched_getscheduler(0) != os.SCHED_FIFO:
            return
        priority = os.sched_getparam(0).sched_priority
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(max(1, priority - 1)))
    except (OSError, AttributeError):  # not Linux, or not permitted: the inherited policy stays
        return
