"""The supervisor's tick over a bus (a board on serial-v1 or can-v1), the two paths it takes.

- `PythonTickPath`: the transport's latest() and send() in Python around the two C halves
  of the tick (rtcore_tick_control, rtcore_tick_follow); the transport's threads decode and
  encode. Every bus transport can.
- `BusTickPath`: a transport that runs the tick in C (transports/in_c.BusTickInC: can-v1 on
  the DBC it was generated from, transports/can_tick.py). Decoding the batch of received
  frames, the control half, encoding the command frames and the follow check are one C
  call; `tick_at` also sleeps to the deadline in that call, so no Python runs from the
  wake-up to the end of the tick, as on the simulated hand. The link's and the firmware's
  checks (Python, read from the transport's threads) run just before: on the scheduled
  path before the sleep, so what they find acts on the tick after the sleep (a status
  arrives at 10 Hz; the checks themselves run in the reader thread as frames arrive).
"""

from __future__ import annotations

import contextlib
import time
from typing import Any

from hand_service.service.safety import Cause, Fault
from hand_service.service.states import ACTIVE, REFS, State
from hand_service.service.tick_path import Ticked, TickPath, sleep_to
from rtcore import clock
from rtcore.tick import FOUND_LEAK, Tick


class PythonTickPath(TickPath):
    """A tick on a transport in Python (a bus): read, the C control half, send, the C
    follow half."""

    def __init__(self, sup: Ticked, ts: Tick) -> None:
        super().__init__(sup, ts)
        self._control, self._follow = ts.control, ts.follow

    def before_handshake(self) -> None:
        """The transport's threads run the exchange: nothing to pause."""

    def advance(self) -> None:
        """The board lives on its own clock."""

    def tick(self, state: State, woke_ns: int) -> None:
        sup = self.sup
        inputs = sup.hand.inputs
        transport_fault = firmware_fault = None
        try:
            sup.transport.on_tick(sup.tick_index)
            sample = sup.transport.latest()
            status = sup.transport.status()
            transport_fault = sup.gate.link_fault(sup.transport.link_problem())
        except Exception as exc:  # any failure of the link is a lost transport
            sample, status = None, None
            transport_fault = Fault(Cause.TRANSPORT_LOST, f"latest(): {type(exc).__name__}: {exc}")
        fresh = sample is not None
        if sample is not None:
            inputs.sensor_mv[:] = sample.sensor_mv
            inputs.pressure_meas_kpa[:] = sample.pressure_meas_kpa
            sup.model_check.newest = sample.sequence
        if status is not None:
            firmware_fault = sup.gate.firmware(status, state in ACTIVE)
        ours = transport_fault or firmware_fault
        events = self._control(REFS[state], ours is not None, sup.missed_last, fresh,
                               sample.lost_in_a_row if sample is not None else 0, woke_ns)
        if events or ours is not None:
            sup.found(events & ~FOUND_LEAK, transport_fault, firmware_fault,
                      sample.sequence if sample is not None else None)
        self._send()
        if self._follow():
            sup.fault(sup.gate.follow_fault(self.ts.follow_result))

    def _send(self) -> None:
        sup = self.sup
        try:
            if sup.machine.vented:
                sup.transport.vent()
            else:
                sup.transport.send(sup.sent_kpa)
        except Exception as exc:
            # a command the wire cannot carry (ValueError: the gate should have caught it), or
            # a link that failed: either way nothing went out this tick, so ask for a vent
            cause = Cause.PRESSURE_OVER_LIMIT if isinstance(exc, ValueError) else Cause.TRANSPORT_LOST
            sup.fault(Fault(cause, f"send(): {type(exc).__name__}: {exc}"))
            with contextlib.suppress(Exception):
                sup.transport.vent()
            sup.sent_kpa[:] = 0.0

    def tick_at(self, deadline_ns: int, state: State) -> tuple[int, int] | None:
        if (woke := sleep_to(self.sup, deadline_ns)) is None:
            return None
        self.tick(state, woke)
        self.sup.record_row(self.sup.machine.state)
        end = clock.now_ns()
        time.sleep(0)  # the transport's writer thread sends the command before the model check
        return woke, end


class BusTickPath(TickPath):
    """The tick over can-v1 in C (transports/can_tick.CanTick)."""

    def __init__(self, sup: Ticked, ts: Tick, bus: Any) -> None:
        super().__init__(sup, ts)
        self.bus = bus
        self._times_ns = Tick.times()  # its wake-up and end

    def _checks(self, state: State) -> tuple[Fault | None, Fault | None]:
        """The link's and the firmware's checks, as PythonTickPath runs them."""
        sup = self.sup
        transport_fault = firmware_fault = None
        try:
            status = sup.transport.status()
            transport_fault = sup.gate.link_fault(sup.transport.link_problem())
        except Exception as exc:  # any failure of the link is a lost transport
            status = None
            transport_fault = Fault(Cause.TRANSPORT_LOST, f"status(): {type(exc).__name__}: {exc}")
        if status is not None:
            firmware_fault = sup.gate.firmware(status, state in ACTIVE)
        return transport_fault, firmware_fault

    def _found(self, events: int, transport_fault: Fault | None, firmware_fault: Fault | None) -> None:
        sup, sequence = self.sup, self.bus.sequence
        sup.model_check.newest = sequence
        if events & ~FOUND_LEAK or transport_fault or firmware_fault:
            sup.found(events & ~FOUND_LEAK, transport_fault, firmware_fault, sequence)
        if events & FOUND_LEAK:
            sup.fault(sup.gate.follow_fault(self.ts.follow_result))

    def _resume(self) -> None:
        """The first C tick after the handshake finds its batch empty (the reader emptied it):
        its inputs start from the newest sample the reader decoded, not from the one before the
        reset (a fault's NaN pressure, say, read again at tick 1)."""
        if self.bus.taking:
            return
        sample = self.sup.transport.latest()
        if sample is not None:
            self.sup.hand.inputs.sensor_mv[:] = sample.sensor_mv
            self.sup.hand.inputs.pressure_meas_kpa[:] = sample.pressure_meas_kpa

    def before_handshake(self) -> None:
        self.bus.pause()

    def advance(self) -> None:
        """The board lives on its own clock."""

    def tick(self, state: State, woke_ns: int) -> None:
        """The tick in C over the bus, on a wake-up the caller slept to."""
        self._resume()
        faults = self._checks(state)
        sup = self.sup
        events = self.bus.tick(REFS[state], any(faults) or sup.machine.vented, sup.missed_last, woke_ns)
        self._found(events, *faults)
        self.bus.after()

    def tick_at(self, deadline_ns: int, state: State) -> tuple[int, int] | None:
        """The checks, then the sleep and the tick in one C call, then what it found and
        the ring row."""
        self._resume()
        faults = self._checks(state)
        sup, bus = self.sup, self.bus
        vent = any(faults) or sup.machine.vented
        times = self._times_ns
        while (events := bus.tick_at(deadline_ns, sup.spin_ns, REFS[state], vent, sup.missed_last,
                                     times)) < 0:
            clock.check_sleep(times[0])  # a signal woke the sleep: nothing was done
            if sup.stop_reason is not None:
                return None
        woke, end = int(times[0]), int(times[1])
        bus.after()  # the writer sends the frames
        self._found(events, *faults)
        sup.record_row(sup.machine.state)
        time.sleep(0)  # the transport's writer thread sends the command before the model check
        return woke, end
