"""Change values in a YAML file in place, line by line, so its comments and layout survive.

    update_values(path, [(("hand", "index", "pressure_gain_nm_per_kpa"), 8.95e-3)], load_profile)

A key that exists has its value replaced on its own line (block or flow style, the
comment after it kept). A key that does not exist is added after the last line of its
mapping, at that mapping's indentation, with any missing parent mappings. The edited
text is validated by the caller's loader before it replaces the file (atomically), so a
failed update leaves the file as it was.
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from hand_service.config.textfile import read_text
from hand_service.config.yamlio import LineDict, parse_yaml
from hand_service.errors import UserError

KeyPath = tuple[str, ...]
_VALUE = r"(?P<value>[^\s,}\]#]+)"


def format_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return f"{value:.7g}"
    return str(value)


def _last_line(node: LineDict) -> int:
    lines = [node.line_of(k) or 0 for k in node]
    lines += [_last_line(v) for v in node.values() if isinstance(v, LineDict) and v]
    return max(lines, default=node.line or 0)


def _indent_of(lines: list[str], node: LineDict, path: Path, where: str) -> str:
    if not node:
        raise UserError(f"{path}: {where} is empty; add the key by hand")
    key = str(next(iter(node)))
    first = lines[(node.line_of(key) or 1) - 1]
    if not first.lstrip().startswith(key):  # `{key: ...}`: flow style
        raise UserError(f"{path}:{node.line_of(key)}: {where} is a flow mapping {{...}}; "
                        "cannot add a key to it "
                        "line by line: rewrite it in block style")
    return first[: len(first) - len(first.lstrip())]


def _replace_on_line(lines: list[str], number: int, key: str, value: str, path: Path) -> None:
    line = lines[number - 1]
    code, hash_, comment = line.partition("#")
    pattern = re.compile(rf"(?P<head>(?:^|[\s{{,]){re.escape(key)}\s*:\s*){_VALUE}")
    new_code, count = pattern.subn(lambda m: m.group("head") + value, code, count=1)
    if count != 1:
        raise UserError(f"{path}:{number}: cannot find the value of '{key}' on this line to replace it")
    lines[number - 1] = new_code + hash_ + comment


def set_value(text: str, keys: KeyPath, value: Any, path: Path) -> str:
    """`text` with the value at `keys` set (replaced in place, or added)."""
    data = parse_yaml(text, path)
    if not isinstance(data, LineDict):
        raise UserError(f"{path}: not a mapping of keys")
    lines = text.split("\n")
    node: LineDict = data
    depth = 0
    while depth < len(keys) - 1 and isinstance(node.get(keys[depth]), LineDict):
        node = node[keys[depth]]
        depth += 1
    where = ".".join(keys[:depth]) or "the top level"
    last = keys[-1]
    if depth == len(keys) - 1 and last in node:
        if isinstance(node[last], dict):
            raise UserError(f"{path}:{node.line_of(last)}: '{'.'.join(keys)}' is a mapping, not a value")
        _replace_on_line(lines, node.line_of(last) or 0, last, format_value(value), path)
        return "\n".join(lines)
    if depth < len(keys) - 1 and keys[depth] in node:
        raise UserError(f"{path}:{node.line_of(keys[depth])}: '{'.'.join(keys[:depth + 1])}' "
                        "is not a mapping")
    indent = "" if node is data else _indent_of(lines, node, path, where)
    step = "  "
    new = [f"{indent}{step * i}{key}:" for i, key in enumerate(keys[depth:-1])]
    new.append(f"{indent}{step * (len(keys) - 1 - depth)}{last}: {format_value(value)}")
    at = _last_line(node) if node else len(lines)
    return "\n".join(lines[:at] + new + lines[at:])


def update_values(path: str | Path, updates: Sequence[tuple[KeyPath, Any]],
                  validate: Callable[[Path], object]) -> None:
    """Apply every update to the file, validate the result with `validate`, then replace it."""
    path = Path(path)
    text = read_text(path)
    for keys, value in updates:
        text = set_value(text, keys, value, path)
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


__all__ = ["format_value", "set_value", "update_values"]
