"""What a transport may offer beside its I/O: a tick that runs in C.

The Transport contract (base.py) is I/O only: open, latest, send, status, close. A transport
whose exchange can run inside the supervisor's C tick says so by also being one of these;
the supervisor picks its tick path from them once, when it is made (service/tick_path.py).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any

from rtcore.sim_link import SimLink


class HandInProcess(ABC):
    """The simulated hand in this process, its link state in C (rtcore.sim_link)."""

    @abstractmethod
    def core_link(self) -> SimLink | None:
        """The link the whole tick, sensors to valves, runs on in one C call; None when this
        transport's exchange must go through its Python methods (a fake with faults)."""


class BusTickInC(ABC):
    """A bus whose frames the supervisor's tick decodes and encodes in C (can-v1)."""

    @abstractmethod
    def bus_tick(self, tick: Any) -> Any:
        """The tick over this bus in one C call (transports/can_tick.CanTick) for the
        supervisor's rtcore.tick.Tick, or None (the tick goes through latest() and send());
        from then on the transport routes its samples to it."""
