"""Transports by name, as python-can does it: kind -> (module, class), imported on demand.

Each module may register the profile keys of its kind in profile.TRANSPORT_SECTIONS.
"""

from __future__ import annotations

import importlib

from hand_service.errors import UserError
from hand_service.transports.base import (
    FirmwareStatus,
    HandshakeError,
    SensorSample,
    Transport,
    TransportHealth,
)

REGISTRY: dict[str, tuple[str, str]] = {
    "sim": ("hand_service.transports.sim", "SimTransport"),
}


def transport_class(kind: str) -> type[Transport]:
    if kind not in REGISTRY:
        raise UserError(f"unknown transport '{kind}' (known: {', '.join(sorted(REGISTRY))})")
    module_name, class_name = REGISTRY[kind]
    return getattr(importlib.import_module(module_name), class_name)


__all__ = ["REGISTRY", "FirmwareStatus", "HandshakeError", "SensorSample", "Transport",
           "TransportHealth", "transport_class"]
