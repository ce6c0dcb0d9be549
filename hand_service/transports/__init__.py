"""Transports by name, as python-can does it: the kind's module and class, imported on demand.

The table of kinds (config/transports.py) is the profile's as well; nothing here writes
into it.
"""

from __future__ import annotations

import importlib

from hand_service.config.transports import KINDS
from hand_service.errors import UserError
from hand_service.transports.base import (
    FirmwareStatus,
    HandshakeError,
    SensorSample,
    Transport,
    TransportHealth,
)

REGISTRY: dict[str, tuple[str, str]] = {name: (kind.module, kind.class_name)
                                         for name, kind in KINDS.items()}


def transport_class(kind: str) -> type[Transport]:
    if kind not in REGISTRY:
        raise UserError(f"unknown transport '{kind}' (known: {', '.join(sorted(REGISTRY))})")
    module_name, class_name = REGISTRY[kind]
    return getattr(importlib.import_module(module_name), class_name)


__all__ = ["REGISTRY", "FirmwareStatus", "HandshakeError", "SensorSample", "Transport",
           "TransportHealth", "transport_class"]
