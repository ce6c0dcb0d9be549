"""The supervisor learns the firmware's state over each bus, against the mock firmware: a
vent it did not ask for while it commands is firmware_vented; a fault injected on the
debug port is not a fault of the board; a fault of the board's own is firmware_fault.

The supervisor runs in this process on every rig (the mock in a thread on the virtual
bus, in another process over SLCAN and serial), so the test can stall its tick while the
transport's I/O threads run on, as a tick held up by a slow request or a long pause of
the interpreter would be. Every wait is for an event, bounded generously."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pytest

from hand_service.firmware.rig import Rig
from hand_service.service.safety import Cause
from hand_service.service.states import Event, State
from hand_service.service.supervisor import Supervisor
from hand_service.transports.can_tick import CommandFrames
from hand_service.transports.link import LinkTransport
from hand_service.wire.can_codec import CanCodec
from hand_service.wire.messages import FaultKind, FirmwareFault, ValveCommand
from rtcore import MODE_POSITION, clock
from tests.hil.test_valve_board import WAIT_S, wait_for

LITTLE = 4  # left vented: a fault injected on it changes nothing the supervisor drives


class Host:
    """An in-process supervisor over the rig's transport, ticked on its own schedule."""

    def __init__(self, rig: Rig) -> None:
        rig.start_mock()
        self.transport: LinkTransport = rig.transport()
        self.sup = Supervisor(rig.profile, self.transport)
        self.schedule = clock.Schedule(self.sup.period_ns)
        self.sup.schedule = self.schedule
        self.max_ticks = round(5 * WAIT_S * self.sup.rate_hz)  # a bound, never a duration

    def tick_until(self, done: object) -> bool:
        for _ in range(self.max_ticks):
            if done():  # type: ignore[operator]
                return True
            self.sup.run_one(self.schedule)
        return bool(done())  # type: ignore[operator]

    def running(self) -> None:
        """DISARMED, then RUNNING with the index finger held at 30 deg, its commands applied
        by the board (the firmware reports running, the samples acknowledge them)."""
        sup = self.sup
        assert self.tick_until(lambda: sup.state is not State.INIT), sup.faults.faults
        assert sup.state is State.DISARMED, sup.faults.faults
        index = sup.names.index("index")
        sup.targets.mode[index] = MODE_POSITION
        sup.targets.angle_deg[index] = 30.0
        sup.fire(Event.ARM)
        sup.fire(Event.START)
        started = self.transport.command_sequence
        acked = []

        def applied() -> bool:
            status = self.transport.status()
            acked.append(sup.state is State.RUNNING and self.transport.command_sequence > started)
            return bool(status and status.state == "running" and sum(acked) > 20)

        assert self.tick_until(applied), (sup.faults.faults, self.transport.status())
        assert sup.state is State.RUNNING, sup.faults.faults

    def close(self) -> None:
        self.sup.request_stop("test done")
        self.sup.shutdown()


@pytest.fixture
def rig(tolerant_rig: Rig) -> Rig:
    """These tests attribute the board's faults; they do not test the sample-age bound
    (tests/hil/tolerant.py): a late sample on a loaded machine latched before the injected
    firmware fault."""
    return tolerant_rig


@pytest.fixture
def host(rig: Rig) -> Iterator[Host]:
    bench = Host(rig)
    try:
        yield bench
    finally:
        bench.close()


def test_a_host_stall_past_the_watchdog_is_firmware_vented(rig: Rig, host: Host) -> None:
    host.running()
    assert host.sup.sent_kpa.max() > 0.0  # pressurised: the next command would be too, unless vented
    vents = len(rig.vent_times_s())
    # the tick stalls: no command goes out, the board's watchdog vents, the host hears it
    assert wait_for(lambda: len(rig.vent_times_s()) > vents), "the firmware did not vent"
    assert wait_for(lambda: host.transport.status().vented)  # type: ignore[union-attr]
    # the tick resumes, and faults before its first command steps the chamber from 0 kPa
    sent_before = host.transport.command_sequence
    given: list[np.ndarray] = []  # every valve command the writer sends (a vent is all zeros)
    encode = host.transport._encode

    def spy(message: object) -> list[object]:
        units = encode(message)
        if isinstance(message, ValveCommand):
            given.append(np.array(message.pressure_cmd_kpa, dtype=float))
        elif isinstance(message, CommandFrames):  # the tick in C encoded it (transports/can_tick.py)
            codec = CanCodec(host.transport.settings["dbc"], host.transport.n_fingers)
            given.extend(np.array(m.pressure_cmd_kpa) for unit in units for m in codec.decode(unit))
        return units

    host.transport._encode = spy  # type: ignore[method-assign]
    host.sup.run_one(host.schedule)
    assert wait_for(lambda: len(given) >= 1), "no command went out"
    assert host.sup.state is State.FAULT
    assert [f.cause for f in host.sup.faults.faults] == [Cause.FIRMWARE_VENTED]
    assert "watchdog_vented" in host.sup.faults.faults[0].detail
    # one command went out, and it is a vent: 0 kPa on every finger (the sequence alone
    # would count a pressurised command the same)
    assert host.transport.command_sequence == sent_before + 1
    assert len(given) == 1 and np.all(given[0] == 0.0), given
    assert host.sup.sent_kpa.max() == 0.0


def test_a_debug_fault_is_not_the_boards_own(rig: Rig, host: Host) -> None:
    host.running()
    transport, sup = host.transport, host.sup
    transport.inject_fault(FaultKind.STUCK_SENSOR, LITTLE)  # until cleared
    assert host.tick_until(lambda: transport.status().injected_fault == FaultKind.STUCK_SENSOR)  # type: ignore[union-attr]
    ticks = sup.stats.ticks
    assert host.tick_until(lambda: sup.stats.ticks >= ticks + 20)
    assert sup.state is State.RUNNING, sup.faults.faults
    assert sup.faults.total == 0
    assert transport.status().fault_code == 0  # type: ignore[union-attr]

    # a fault the board finds in itself is the board's: it vents, the supervisor latches
    transport.inject_fault(FaultKind.FIRMWARE_FAULT, value=FirmwareFault.PRESSURE_SENSOR)
    assert host.tick_until(lambda: sup.state is State.FAULT)
    assert [f.cause for f in sup.faults.faults] == [Cause.FIRMWARE_FAULT]
    assert sup.faults.faults[0].detail == "firmware reports fault 2: pressure_sensor"
    status = transport.status()
    assert status is not None and status.vented and status.state == "fault"
