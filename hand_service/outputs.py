"""Output paths checked before a long run, so that a typo costs a second, not the run."""

from __future__ import annotations

import os
from pathlib import Path

from hand_service.errors import UserError


def check_writable(path: Path | str) -> None:
    """Refuse now an output file that cannot be written ('-', stdout, always can)."""
    if str(path) == "-":
        return
    target = Path(path)
    if target.is_dir():
        raise UserError(f"{path}: cannot write: Is a directory")
    if not target.parent.is_dir():
        raise UserError(f"{path}: cannot write: no directory {target.parent}")
    if not os.access(target.parent, os.W_OK) or (target.exists() and not os.access(target, os.W_OK)):
        raise UserError(f"{path}: cannot write: Permission denied")


def make_directory(path: Path) -> None:
    """An output directory, created with its parents when missing."""
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UserError(f"{path}: cannot create: {exc.strerror or exc}") from None
