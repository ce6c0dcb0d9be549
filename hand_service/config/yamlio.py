"""YAML in and out, keeping the line of every key so errors can point at it.

Files are read by ruamel.yaml's round-trip loader, which gives, beyond plain yaml.safe_load:
- the line of every mapping and key (`lc`), kept in a LineDict;
- a key given twice is an error (ruamel's DuplicateKeyError);
- `1e-3` is a number (YAML 1.2; YAML 1.1 wanted `1.0e-3`).
Here on top: every key is text, and any bad input (bytes that are not UTF-8, a tag that
cannot make its value, nesting too deep) is a one-line UserError naming the line, never
another exception.
"""

from __future__ import annotations

import datetime
import warnings
from collections.abc import Set as AbstractSet
from pathlib import Path
from typing import Any

import yaml
from ruamel.yaml import YAML
from ruamel.yaml.comments import CommentedMap, TaggedScalar
from ruamel.yaml.composer import ReusedAnchorWarning
from ruamel.yaml.constructor import ConstructorError, RoundTripConstructor
from ruamel.yaml.error import MarkedYAMLError, YAMLError
from ruamel.yaml.nodes import Node, ScalarNode
from ruamel.yaml.reader import ReaderError

from hand_service.config.textfile import read_text, show
from hand_service.errors import UserError, where

_PLAIN_TAGS = {"tag:yaml.org,2002:str": str}


class LineDict(dict):
    """A mapping from YAML that remembers its own line and each key's line (1-based)."""

    line: int | None = None
    key_lines: dict[str, int]

    def line_of(self, key: str) -> int | None:
        return getattr(self, "key_lines", {}).get(key, self.line)


def _one_line(text: object) -> str:
    return " ".join(str(text).split())


class _Constructor(RoundTripConstructor):
    def construct_object(self, node: Node, deep: bool = False) -> Any:
        """A value its tag cannot make (`!!int 1e3`, `!!timestamp x`, an integer of 5000
        digits) is an error at that value's line, not a Python exception."""
        try:
            return super().construct_object(node, deep=deep)
        except YAMLError:
            raise
        except (ValueError, TypeError, KeyError, IndexError, AttributeError, OverflowError) as exc:
            what = f" {show(node.value)}" if isinstance(node, ScalarNode) else ""
            tag = str(node.tag).rsplit(":", 1)[-1]
            raise ConstructorError(None, None, f"cannot read{what} as {tag} ({type(exc).__name__})",
                                   node.start_mark) from None


def _yaml() -> YAML:
    loader = YAML(typ="rt")
    loader.Constructor = _Constructor
    return loader


class _BadValue(Exception):
    def __init__(self, message: str, line: int | None) -> None:
        super().__init__(message)
        self.line = line


def _plain(value: Any, line: int | None) -> Any:
    """ruamel's round-trip objects as plain Python: LineDict, list, str, int, float, bool."""
    if isinstance(value, CommentedMap):
        return _mapping(value)
    if isinstance(value, dict):
        return {k: _plain(v, line) for k, v in value.items()}
    if isinstance(value, TaggedScalar):
        tag = str(value.tag)
        if tag in _PLAIN_TAGS:
            return _PLAIN_TAGS[tag](value.value)
        raise _BadValue(f"could not determine a constructor for the tag {tag!r}", line)
    if isinstance(value, (list, tuple)):
        return [_plain(v, line) for v in value]
    if isinstance(value, AbstractSet):
        return {_plain(v, line) for v in value}
    if isinstance(value, bool):
        return bool(value)
    if isinstance(value, int):
        return int(value)
    if isinstance(value, float):
        return float(value)
    if isinstance(value, str):
        return str(value)
    if isinstance(value, datetime.datetime):
        return datetime.datetime.fromisoformat(value.isoformat())
    return value


def _mapping(node: CommentedMap) -> LineDict:
    mapping = LineDict()
    mapping.line = node.lc.line + 1
    mapping.key_lines = {}
    for key, value in node.items():
        try:
            key_line = node.lc.key(key)[0] + 1
        except (KeyError, TypeError):  # a key merged in by `<<` has no place of its own here
            key_line = mapping.line
        if not isinstance(key, str):
            shown = _plain(key, key_line) if isinstance(key, tuple) else key
            raise _BadValue(f"key {show(shown)} is not a name: every key is text", key_line)
        try:
            value_line = node.lc.value(key)[0] + 1
        except (KeyError, TypeError):
            value_line = key_line
        mapping[str(key)] = _plain(value, value_line)
        mapping.key_lines[str(key)] = key_line
    return mapping


def load_yaml(path: str | Path) -> Any:
    """Parse a YAML file; a missing file or bad syntax is a UserError naming the line."""
    return parse_yaml(read_text(path), Path(path))


def parse_yaml(text: str, path: str | Path) -> Any:
    """Parse YAML text as load_yaml does; `path` names it in errors. Every error is one line."""
    if flow_too_deep(text):
        raise UserError(f"{path}: not valid YAML: nested too deeply (more than {MAX_FLOW_DEPTH} "
                        "levels of [ or {)")
    try:
        with warnings.catch_warnings():  # an anchor defined twice: the later one holds, as in YAML 1.1
            warnings.simplefilter("ignore", ReusedAnchorWarning)
            document = _load(text, path)
        return _plain(document, None)
    except _BadValue as exc:
        raise UserError(f"{where(path, exc.line)}: {exc}") from None
    except MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = mark.line + 1 if mark else None
        raise UserError(f"{where(path, line)}: {_one_line(exc.problem or exc.context)}") from None
    except ReaderError as exc:
        line = text[: exc.position].count("\n") + 1
        character = chr(exc.character) if isinstance(exc.character, int) else exc.character
        raise UserError(f"{where(path, line)}: the character {show(character)} is not allowed in YAML "
                        f"({_one_line(exc.reason)})") from None
    except YAMLError as exc:
        raise UserError(f"{path}: not valid YAML: {_one_line(exc)}") from None
    except RecursionError:
        raise UserError(f"{path}: not valid YAML: nested too deeply") from None


# Flow collections (`[`, `{`) nested deeper than this are refused before ruamel reads them: its
# scanner's time grows with the square of the depth until the recursion limit stops it; no
# profile or model needs more than a few levels.
MAX_FLOW_DEPTH = 100


def flow_too_deep(text: str) -> bool:
    """Whether `[` and `{` outside quotes and comments (YAML's flow collections) nest deeper
    than MAX_FLOW_DEPTH."""
    if text.count("[") + text.count("{") <= MAX_FLOW_DEPTH:
        return False
    depth = 0
    quote = ""
    previous = "\n"
    comment = escaped = False
    for char in text:
        if comment:
            comment = char != "\n"
        elif escaped:  # the character after a backslash in a double-quoted scalar
            escaped = False
        elif quote:
            if char == quote:
                quote = ""
            escaped = quote == '"' and char == "\\"
        elif char in "'\"" and previous in " \t\n[{,:-":  # a quoted scalar starts; "finger's" is plain
            quote = char
        elif char == "#" and previous in " \t\n":
            comment = True
        elif char in "[{":
            depth += 1
            if depth > MAX_FLOW_DEPTH:
                return True
        elif char in "]}":
            depth = max(depth - 1, 0)
        previous = char
    return False


def _load(text: str, path: str | Path) -> Any:
    """ruamel's load; a key that is itself a mapping (`? {a: 1}: x`, or a block mapping under
    a `?`) makes ruamel test it as a dict key and fail with TypeError: refused in one line."""
    try:
        return _yaml().load(text)
    except TypeError as exc:
        raise UserError(f"{path}: not valid YAML: a mapping used as a key ({_one_line(exc)})") from None


def dump_yaml(data: dict[str, Any]) -> str:
    """Block-style YAML with keys in the order given."""
    return yaml.safe_dump(_dumpable(data), sort_keys=False, default_flow_style=False)


def _dumpable(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _dumpable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_dumpable(v) for v in value]
    if hasattr(value, "item"):  # numpy scalars
        return value.item()
    return value

