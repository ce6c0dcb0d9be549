"""The supervisor's status snapshot (surface.Status) from the step's structs and the link."""

from __future__ import annotations

import numpy as np

from hand_service.service.safety import finite_or_none
from hand_service.service.surface import FingerStatus, FirmwareSummary, TransportStatus
from hand_service.transports import Transport
from rtcore import MODE_FORCE, MODE_IMPEDANCE, MODE_POSITION, Hand
from rtcore.config import MODE_NAMES, flag_names
from rtcore.tick import Targets


def finger_status(names: list[str], hand: Hand, targets: Targets,
                  sent_kpa: np.ndarray) -> dict[str, FingerStatus]:
    """Each finger as the last tick left it."""
    inputs, outputs = hand.inputs, hand.outputs
    fingers = {}
    for i, name in enumerate(names):
        mode = int(inputs.mode[i])
        fingers[name] = FingerStatus(
            mode=MODE_NAMES.get(mode, "?"),
            target_mode=MODE_NAMES.get(int(targets.mode[i]), "?"),
            angle_deg=float(outputs.angle_deg[i]),
            angle_filt_deg=float(outputs.angle_filt_deg[i]),
            angle_ref_deg=(float(inputs.angle_ref_deg[i]) if mode in (MODE_POSITION, MODE_IMPEDANCE)
                           else None),
            force_ref_n=float(inputs.force_ref_n[i]) if mode == MODE_FORCE else None,
            pressure_cmd_kpa=float(sent_kpa[i]),
            pressure_meas_kpa=finite_or_none(float(inputs.pressure_meas_kpa[i])),
            force_est_n=float(outputs.force_normal_n[i]),
            flags=flag_names(int(outputs.flags[i])))
    return fingers


def transport_status(transport: Transport, link_open: bool) -> TransportStatus:
    """The link, and what the firmware last said of itself (while the link is open)."""
    firmware = transport.status() if link_open else None
    return TransportStatus(
        kind=transport.kind, open=link_open,
        health=transport.health().as_dict() if link_open else None,
        firmware=None if firmware is None else FirmwareSummary(
            protocol_version=firmware.protocol_version, firmware_version=firmware.firmware_version,
            vented=firmware.vented, fault_code=firmware.fault_code, fault_text=firmware.fault_text),
        link=transport.link_estimates() if link_open else {})
