"""The export formats' libraries that are not core dependencies: one clear line when missing."""

from __future__ import annotations

import importlib
from types import ModuleType

from hand_service.errors import UserError

# module -> the pip package that provides it
PACKAGES = {"pyarrow": "pyarrow", "pyarrow.parquet": "pyarrow", "mcap": "mcap", "mcap.writer": "mcap"}


def need(module: str) -> ModuleType:
    """Import `module`, or a UserError saying how to install it."""
    try:
        return importlib.import_module(module)
    except ImportError:
        package = PACKAGES.get(module, module.split(".")[0])
        raise UserError(f"this format needs the Python package '{package}': "
                        f"pip install 'hand-service[export]' (or pip install {package})") from None
