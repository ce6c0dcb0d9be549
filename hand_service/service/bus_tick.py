"""The supervisor's tick over a bus (a board on serial-v1 or can-v1), the two ways it runs.

- `python_tick`: the transport's latest() and send() in Python around the two C halves of
  the tick (rtcore_tick_control, rtcore_tick_follow); the transport's threads decode and
  encode. Every bus transport can.
- `tick_at` and `tick`: a transport that runs the tick in C (Transport.bus_tick: can-v1 on
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
from rtcore import clock
from rtcore.tick import FOUND_LEAK

# `sup`: the Supervisor (service/supervisor.py), whose tick these are; not imported here,
# which would be a cycle
Supervisor = Any


def python_tick(sup: Supervisor, state: State, woke_ns: int) -> None:
    """A tick on a transport in Python (a bus): read, the C control half, send, the C
    follow half."""
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
    events = sup._control(REFS[state], ours is not None, sup._last_missed, fresh,
                          sample.lost_in_a_row if sample is not None else 0, woke_ns)
    if events or ours is not None:
        sup._found(events & ~FOUND_LEAK, transport_fault, firmware_fault,
                   sample.sequence if sample is not None else None)
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
    if sup._follow():
        sup.fault(sup.gate.follow_fault(sup._ts.follow_result))


def _checks(sup: Supervisor, state: State) -> tuple[Fault | None, Fault | None]:
    """The link's and the firmware's checks, as python_tick runs them."""
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


def _found(sup: Supervisor, events: int, transport_fault: Fault | None, firmware_fault: Fault | None) -> None:
    bus = sup._bus_tick
    sup.model_check.newest = bus.sequence
    if events & ~FOUND_LEAK or transport_fault or firmware_fault:
        sup._found(events & ~FOUND_LEAK, transport_fault, firmware_fault, bus.sequence)
    if events & FOUND_LEAK:
        sup.fault(sup.gate.follow_fault(sup._ts.follow_result))


def _resume(sup: Supervisor) -> None:
    """The first C tick after the handshake finds its batch empty (the reader emptied it):
    its inputs start from the newest sample the reader decoded, not from the one before the
    reset (a fault's NaN pressure, say, read again at tick 1)."""
    if sup._bus_tick.taking:
        return
    sample = sup.transport.latest()
    if sample is not None:
        sup.hand.inputs.sensor_mv[:] = sample.sensor_mv
        sup.hand.inputs.pressure_meas_kpa[:] = sample.pressure_meas_kpa


def tick(sup: Supervisor, state: State, woke_ns: int) -> None:
    """The tick in C over the bus, on a wake-up the caller slept to."""
    _resume(sup)
    faults = _checks(sup, state)
    events = sup._bus_tick.tick(REFS[state], any(faults) or sup.machine.vented, sup._last_missed, woke_ns)
    _found(sup, events, *faults)
    sup._bus_tick.after()


def tick_at(sup: Supervisor, deadline_ns: int, state: State) -> tuple[int, int] | None:
    """The scheduled tick in C over the bus: the checks, then the sleep and the tick in one
    C call, then what it found and the ring row. Its wake-up and end (ns), or None when a
    signal woke the sleep and the loop is to stop."""
    _resume(sup)
    faults = _checks(sup, state)
    vent = any(faults) or sup.machine.vented
    times = sup._times_ns
    bus = sup._bus_tick
    while (events := bus.tick_at(deadline_ns, sup.spin_ns, REFS[state], vent, sup._last_missed, times)) < 0:
        clock.check_sleep(times[0])  # a signal woke the sleep: nothing was done
        if sup.stop_reason is not None:
            return None
    woke, end = int(times[0]), int(times[1])
    bus.after()  # the writer sends the frames
    _found(sup, events, *faults)
    sup._record(sup.machine.state)
    time.sleep(0)  # the transport's writer thread sends the command before the model check
    return woke, end
