"""JSON out: numpy values made plain, non-finite numbers as null, '-' for stdout."""

from __future__ import annotations

import contextlib
import json
import math
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from hand_service.errors import UserError


def plain(value: Any) -> Any:
    """Dicts, lists and numbers that json can write (NaN and Inf become None)."""
    if isinstance(value, dict):
        return {str(k): plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    if hasattr(value, "tolist"):  # numpy arrays and scalars
        return plain(value.tolist())
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def write_json(path: Path | str, data: Any) -> None:
    text = json.dumps(plain(data), indent=2) + "\n"
    if str(path) == "-":
        sys.stdout.write(text)
        return
    try:
        Path(path).write_text(text)
    except OSError as exc:
        raise UserError(f"{path}: cannot write: {exc.strerror or exc}") from None


@contextlib.contextmanager
def tables_out(json_path: Path | str | None) -> Iterator[None]:
    """Send what a command prints to stderr while its JSON goes to stdout (`--json -`)."""
    if json_path is not None and str(json_path) == "-":
        with contextlib.redirect_stdout(sys.stderr):
            yield
    else:
        yield
