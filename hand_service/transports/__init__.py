"""Transports by name, as python-can does it: kind -> (module, class), imported on demand.

Each kind registers its profile keys in profile.TRANSPORT_SECTIONS when this package is
imported (the bus kinds' keys live in transports/sections.py, which loads no bus library).
"""

from __future__ import annotations

import importlib

from hand_service import profile as _profile
from hand_service.errors import UserError
from hand_service.transports import sections as _sections
from hand_service.transports.base import (
    FirmwareStatus,
    HandshakeError,
    SensorSample,
    Transport,
    TransportHealth,
)

REGISTRY: dict[str, tuple[str, str]] = {
    "sim": ("hand_service.transports.sim", "SimTransport"),
    "can": ("hand_service.transports.can_transport", "CanTransport"),
    "serial": ("hand_service.transports.serial_transport", "SerialTransport"),
}
_profile.TRANSPORT_SECTIONS.update(_sections.SECTIONS)
_profile.TRANSPORT_CHECKS.update(_sections.CHECKS)
_profile.TRANSPORT_COMMAND_RANGES.update(_sections.COMMAND_RANGES)


def transport_class(kind: str) -> type[Transport]:
    if kind not in REGISTRY:
        raise UserError(f"unknown transport '{kind}' (known: {', '.join(sorted(REGISTRY))})")
    module_name, class_name = REGISTRY[kind]
    return getattr(importlib.import_module(module_name), class_name)


__all__ = ["REGISTRY", "FirmwareStatus", "HandshakeError", "SensorSample", "Transport",
           "TransportHealth", "transport_class"]
