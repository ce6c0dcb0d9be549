"""How a tick reaches the hand: one TickPath, chosen once when the supervisor is made.

- CoreTickPath (here): the simulated hand in this process. Sensors, gate, references,
  step and valves are one C call on its link (csrc/rtcore_tick.c); on the schedule the
  sleep before and the ring row after are in that call too.
- BusTickPath (bus_tick.py): a board on can-v1 whose frames the tick decodes and encodes
  in C.
- PythonTickPath (bus_tick.py): any bus, through the transport's latest() and send() in
  Python around the two C halves of the tick.

A path owns `tick` (on a wake-up the caller slept to) and `tick_at` (the sleep and the
tick, the row recorded). The state machine, the handshake and the wording of a fault stay
with the supervisor, which a path reaches through `Ticked`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any, Protocol

import numpy as np

from hand_service.service.plausibility import ModelCheck
from hand_service.service.safety import Fault, SafetyGate
from hand_service.service.states import REFS, State, StateMachine
from hand_service.service.timing import TickStats
from hand_service.transports import Transport
from rtcore import Hand, clock
from rtcore.sim_link import SimLink
from rtcore.tick import LinkTick, Tick


class Ticked(Protocol):
    """What a tick path reaches of the supervisor (service/supervisor.py)."""

    machine: StateMachine
    hand: Hand
    gate: SafetyGate
    model_check: ModelCheck
    transport: Transport
    stats: TickStats
    sent_kpa: np.ndarray
    spin_ns: int
    tick_index: int
    t_s: float
    missed_last: bool  # the tick before missed its deadline
    stop_reason: str | None

    def found(self, events: int, transport_fault: Fault | None = None,
              firmware_fault: Fault | None = None, sequence: int | None = None) -> None: ...

    def fault(self, fault: Fault) -> None: ...

    def record_row(self, state: int) -> None: ...


def sleep_to(sup: Ticked, deadline_ns: int) -> int | None:
    """Sleep to the deadline: the wake-up (ns), or None when a signal asked the loop to stop
    (a signal whose handler did not ask for it: sleep on)."""
    woke = clock.sleep_until_ns(deadline_ns, sup.spin_ns)
    while woke < 0:
        if sup.stop_reason is not None:
            return None
        woke = clock.sleep_until_ns(deadline_ns, sup.spin_ns)
    return woke


class TickPath(ABC):
    """One way from the sensors to the valves; the states' references come from REFS."""

    link: SimLink | None = None  # the simulated hand's link, when it lives in this process

    def __init__(self, sup: Ticked, ts: Tick) -> None:
        self.sup = sup
        self.ts = ts

    @abstractmethod
    def tick(self, state: State, woke_ns: int) -> None:
        """The tick in `state` (not INIT) on a wake-up the caller slept to; the caller
        records the row."""

    @abstractmethod
    def tick_at(self, deadline_ns: int, state: State) -> tuple[int, int] | None:
        """Sleep to the deadline and tick in `state` (not INIT), the row recorded: its
        wake-up and end (ns), or None when a signal woke the sleep and the loop stops."""

    @abstractmethod
    def before_handshake(self) -> None:
        """INIT: the handshake runs in Python, outside the path."""

    @abstractmethod
    def advance(self) -> None:
        """In the slack: the hand lives through the period of the command just sent (a
        board does so on its own)."""


class CoreTickPath(TickPath):
    """The simulated hand in this process: from the wake-up to the end of a tick, C only."""

    def __init__(self, sup: Ticked, ts: Tick, link: SimLink) -> None:
        super().__init__(sup, ts)
        self.link = link
        core: LinkTick = ts.on_link(link)
        self._tick, self._tick_at = core.tick, core.tick_at
        self._advance = core.advance
        self._times_ns: Any = Tick.times()  # its wake-up and end

    def before_handshake(self) -> None:
        """The link opens in the handshake; nothing runs ahead of it."""

    def advance(self) -> None:
        self._advance()

    def timed_advance(self) -> list[int]:
        """From now on, the ns each advance takes, appended to the list returned."""
        advance, spent = self._advance, []

        def timed() -> object:
            start = clock.now_ns()
            advance()
            spent.append(clock.now_ns() - start)
            return None

        self._advance = timed
        return spent

    def tick(self, state: State, woke_ns: int) -> None:
        sup = self.sup
        events = self._tick(sup.tick_index, REFS[state], sup.missed_last, woke_ns)
        if events:
            sup.found(events)

    def tick_at(self, deadline_ns: int, state: State) -> tuple[int, int] | None:
        sup = self.sup
        times = self._times_ns
        while (events := self._tick_at(deadline_ns, sup.spin_ns, sup.tick_index, REFS[state],
                                       sup.missed_last, sup.t_s, state, times)) < 0:
            clock.check_sleep(times[0])  # a signal woke the sleep: nothing was done
            if sup.stop_reason is not None:
                return None
        woke, end = times[0], times[1]
        if events:  # the state may change: the row is recorded here, after
            sup.found(events)
            sup.record_row(sup.machine.state)
            end = clock.now_ns()
        else:  # the tick ended in C (its row too): how long until Python ran again, apart
            sup.stats.add_return(clock.now_ns() - end)
        return woke, end
