"""Change values in a YAML file through ruamel.yaml's round trip, so its comments, key
order, quoting, flow or block style and indentation survive.

    update_values(path, [(("hand", "index", "pressure_gain_nm_per_kpa"), 8.95e-3)], load_profile)

A key that exists has its value replaced where it stands; a key that does not exist is
added at the end of its mapping, with any missing parent mappings (in block style). The
new text is validated by the caller's loader before it replaces the file (atomically), so
a failed update leaves the file as it was. Floats are written with 7 significant digits.
"""

from __future__ import annotations

import contextlib
import io
import os
import shutil
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from hand_service.config.textfile import read_text
from hand_service.errors import UserError

KeyPath = tuple[str, ...]
WIDTH = 4096  # never fold a long line the file had on one line


def _yaml(text: str) -> Any:
    from ruamel.yaml import YAML
    from ruamel.yaml.util import load_yaml_guess_indent

    _, indent, block_seq_indent = load_yaml_guess_indent(text)
    yaml = YAML(typ="rt")
    yaml.preserve_quotes = True
    yaml.width = WIDTH
    indent = indent or 2
    offset = block_seq_indent or 0
    yaml.indent(mapping=indent, sequence=max(indent, offset + 2), offset=offset)
    yaml.explicit_start = text.lstrip().startswith("---")
    return yaml


def _value(value: Any) -> Any:
    if isinstance(value, float) and not isinstance(value, bool):
        return float(f"{value:.7g}")
    return value


def set_values(text: str, updates: Sequence[tuple[KeyPath, Any]], path: Path) -> str:
    """`text` with every value at its key path set (replaced in place, or added)."""
    from ruamel.yaml.comments import CommentedMap
    from ruamel.yaml.error import YAMLError

    try:
        yaml = _yaml(text)
        data = yaml.load(text)
    except YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        line = f":{mark.line + 1}" if mark is not None else ""
        raise UserError(f"{path}{line}: not valid YAML: {getattr(exc, 'problem', None) or exc}") from None
    if not isinstance(data, CommentedMap):
        raise UserError(f"{path}: not a mapping of keys")
    for keys, value in updates:
        node = data
        for depth, key in enumerate(keys[:-1]):
            child = node.get(key)
            if child is None and key not in node:
                child = node[key] = CommentedMap()
            if not isinstance(child, CommentedMap):
                raise UserError(f"{path}:{node.lc.key(key)[0] + 1}: '{'.'.join(keys[:depth + 1])}' "
                                "is not a mapping")
            node = child
        last = keys[-1]
        if isinstance(node.get(last), dict):
            raise UserError(f"{path}:{node.lc.key(last)[0] + 1}: '{'.'.join(keys)}' is a mapping, "
                            "not a value")
        node[last] = _value(value)
    out = io.StringIO()
    yaml.dump(data, out)
    return out.getvalue()


def update_values(path: str | Path, updates: Sequence[tuple[KeyPath, Any]],
                  validate: Callable[[Path], object]) -> None:
    """Apply every update to the file, validate the result with `validate`, then replace it."""
    path = Path(path)
    text = set_values(read_text(path), updates, path)
    temporary = path.with_name(f".{path.name}.updating")
    try:
        temporary.write_text(text)
        shutil.copymode(path, temporary)
        try:
            validate(temporary)
        except UserError as exc:
            raise UserError(f"{path}: not updated, the result would be invalid: "
                            f"{str(exc).replace(str(temporary), path.name)}") from None
        os.replace(temporary, path)
    except OSError as exc:
        raise UserError(f"{path}: cannot write: {exc.strerror or exc}") from None
    finally:
        with contextlib.suppress(FileNotFoundError):
            temporary.unlink()


__all__ = ["set_values", "update_values"]
