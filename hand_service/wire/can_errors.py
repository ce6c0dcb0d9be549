"""CAN error frames as python-can delivers them (SocketCAN's encoding, linux/can/error.h).

A CAN controller reports trouble on the bus to its driver, which hands it on as an error
frame: a can.Message with is_error_frame set, whose arbitration id holds the error
classes and whose data the details. SocketCAN, and python-can's interfaces that report
errors, use these classes; a bus state (python-can's BusState) says the same in one word
where the interface keeps one.
"""

from __future__ import annotations

import can

CAN_ERR_TX_TIMEOUT = 0x001
CAN_ERR_LOSTARB = 0x002
CAN_ERR_CRTL = 0x004  # controller problem: data[1] says which
CAN_ERR_PROT = 0x008  # protocol violation: data[2] says which
CAN_ERR_TRX = 0x010
CAN_ERR_ACK = 0x020  # no acknowledge: no other node on the bus
CAN_ERR_BUSOFF = 0x040  # the controller went bus-off: it no longer sends or receives
CAN_ERR_BUSERROR = 0x080
CAN_ERR_RESTARTED = 0x100

CAN_ERR_CRTL_RX_PASSIVE = 0x10  # data[1]: the error counters passed 127
CAN_ERR_CRTL_TX_PASSIVE = 0x20
CAN_ERR_PROT_STUFF = 0x04  # data[2]: a bit-stuffing error

CLASS_NAMES = {CAN_ERR_TX_TIMEOUT: "tx timeout", CAN_ERR_LOSTARB: "lost arbitration",
               CAN_ERR_CRTL: "controller", CAN_ERR_PROT: "protocol violation",
               CAN_ERR_TRX: "transceiver", CAN_ERR_ACK: "no ack", CAN_ERR_BUSOFF: "bus-off",
               CAN_ERR_BUSERROR: "bus error", CAN_ERR_RESTARTED: "controller restarted"}


def is_bus_off(frame: can.Message) -> bool:
    return bool(frame.arbitration_id & CAN_ERR_BUSOFF)


def is_error_passive(frame: can.Message) -> bool:
    """The controller's error counters passed 127: it may no longer signal errors."""
    data = bytes(frame.data)
    return bool(frame.arbitration_id & CAN_ERR_CRTL and len(data) > 1
                and data[1] & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE))


def describe(frame: can.Message) -> str:
    """The error classes an error frame names, in words ("bus error, protocol violation")."""
    names = [name for bit, name in CLASS_NAMES.items() if frame.arbitration_id & bit]
    return ", ".join(names) or f"error frame 0x{frame.arbitration_id:X}"


def error_frame(classes: int, data: bytes = bytes(8)) -> can.Message:
    """An error frame as a driver delivers it (the mock firmware plays the host's driver)."""
    return can.Message(arbitration_id=classes, is_error_frame=True, is_extended_id=False,
                       data=data, dlc=len(data))


def bus_error_frame() -> can.Message:
    """A bus error (a stuffing error seen on the wire): what a noisy or mis-terminated bus gives."""
    return error_frame(CAN_ERR_PROT | CAN_ERR_BUSERROR, bytes((0, 0, CAN_ERR_PROT_STUFF, 0, 0, 0, 0, 0)))


def bus_off_frame() -> can.Message:
    return error_frame(CAN_ERR_BUSOFF)


__all__ = ["CAN_ERR_BUSOFF", "CAN_ERR_CRTL", "CAN_ERR_PROT", "bus_error_frame", "bus_off_frame",
           "describe", "error_frame", "is_bus_off", "is_error_passive"]
