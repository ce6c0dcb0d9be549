"""How the supervisor takes the firmware's word about itself: a fault of the board's own
latches firmware_fault; a vent the board did on its own (watchdog, fault, reboot) latches
firmware_vented while the supervisor commands (RUNNING, HOLD), and is nothing to it while
it vents anyway (DISARMED, ARMED)."""

from __future__ import annotations

from dataclasses import replace

from hand_service.service.safety import Cause
from hand_service.service.states import Event, State
from hand_service.transports.base import FirmwareStatus
from tests.service.conftest import Rig


def test_a_vent_while_running_is_a_fault(rig: Rig) -> None:
    rig.running()
    rig.transport.firmware_vents = 1
    rig.tick()
    rig.assert_faulted("firmware_vented")
    assert "watchdog_vented" in rig.sup.faults.faults[-1].detail


def test_a_vent_while_holding_is_a_fault(rig: Rig) -> None:
    rig.running()
    rig.sup.fire(Event.HOLD)
    rig.tick()
    rig.transport.firmware_vents = 1
    rig.tick()
    rig.assert_faulted("firmware_vented")


def test_a_vent_while_the_supervisor_vents_is_no_fault(rig: Rig) -> None:
    """DISARMED and ARMED send 0 kPa: a board that vented on its own is where they want it;
    starting afterwards is no fault, the count is the same."""
    rig.tick()
    assert rig.sup.state is State.DISARMED
    rig.transport.firmware_vents = 1
    rig.tick(3)
    rig.sup.fire(Event.ARM)
    rig.transport.firmware_vents = 2
    rig.tick(3)
    rig.sup.fire(Event.START)
    rig.tick(20)
    assert rig.sup.state is State.RUNNING, rig.sup.faults.faults
    assert rig.sup.faults.total == 0


def test_a_vent_counted_before_a_reset_is_not_seen_again(rig: Rig) -> None:
    """The gate itself (through the supervisor any DISARMED/ARMED tick would re-baseline the
    count, hiding whether reset() forgets it): the board vented while the gate did not look
    (the supervisor was in FAULT for another cause, its link closed); after the re-handshake
    its count still says so, and only reset() keeps that from faulting the first command."""
    gate = rig.sup.gate
    status = FirmwareStatus(protocol_version=1, firmware_version="test", vents=0)
    assert gate.firmware(status, commanding=True) is None  # seen: no vent yet
    gate.reset()
    assert gate.firmware(replace(status, vents=1), commanding=True) is None  # counted before the reset
    fault = gate.firmware(replace(status, vents=2), commanding=True)  # a vent after it still counts
    assert fault is not None and fault.cause is Cause.FIRMWARE_VENTED


def test_a_firmware_fault_outranks_its_vent(rig: Rig) -> None:
    rig.running()
    rig.transport.fault_code = 1
    rig.transport.firmware_vents = 1
    rig.tick()
    rig.assert_faulted("firmware_fault")
