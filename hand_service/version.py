"""The software version recorded in every file the project writes (provenance)."""

from __future__ import annotations

import functools
import subprocess
from pathlib import Path

from hand_service import __version__

ROOT = Path(__file__).resolve().parent.parent


@functools.cache
def software_version() -> str:
    """`0.1.0+g<hash>[-dirty]` run from this project's git checkout, else the package
    version (an installed copy may sit inside some other checkout: not ours to describe)."""
    if not (ROOT / ".git").exists():
        return __version__
    try:
        described = subprocess.run(
            ["git", "-C", str(ROOT), "describe", "--always", "--dirty", "--abbrev=10"],
            capture_output=True, text=True, timeout=5, check=True,
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return __version__
    return f"{__version__}+g{described}" if described else __version__
