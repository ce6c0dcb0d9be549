"""YAML in and out, keeping the line of every key so errors can point at it.

Differences from plain yaml.safe_load, all in the user's favour:
- every mapping is a LineDict that knows the line of each key;
- a key given twice is an error (YAML would silently keep the last one);
- `1e-3` is a number (YAML 1.1 wants `1.0e-3`, which surprises everyone);
- every key is text;
- any bad input (bytes that are not UTF-8, a tag that cannot make its value, nesting too
  deep) is a one-line UserError naming the line, never another exception.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import yaml

from hand_service.config.textfile import read_text, show
from hand_service.errors import UserError, where


class LineDict(dict):
    """A mapping from YAML that remembers its own line and each key's line (1-based)."""

    line: int | None = None
    key_lines: dict[str, int]

    def line_of(self, key: str) -> int | None:
        return getattr(self, "key_lines", {}).get(key, self.line)


def _one_line(text: object) -> str:
    return " ".join(str(text).split())


class _Loader(yaml.SafeLoader):
    def construct_object(self, node: yaml.Node, deep: bool = False) -> Any:
        """A value its tag cannot make (`!!int 1e3`, `!!timestamp x`, an integer of 5000
        digits) is an error at that value's line, not a Python exception."""
        try:
            return super().construct_object(node, deep=deep)
        except yaml.YAMLError:
            raise
        except (ValueError, TypeError, KeyError, IndexError, AttributeError, OverflowError) as exc:
            what = f" {show(node.value)}" if isinstance(node, yaml.ScalarNode) else ""
            raise yaml.constructor.ConstructorError(
                None, None, f"cannot read{what} as {node.tag.rsplit(':', 1)[-1]} ({type(exc).__name__})",
                node.start_mark) from None


def _construct_mapping(loader: _Loader, node: yaml.MappingNode) -> LineDict:
    try:
        loader.flatten_mapping(node)
    except (TypeError, AttributeError, ValueError):  # a merge key `<<` of something odd
        raise yaml.constructor.ConstructorError(
            None, None, "a merge key '<<' needs a mapping or a list of mappings", node.start_mark) from None
    mapping = LineDict()
    mapping.line = node.start_mark.line + 1
    mapping.key_lines = {}
    for key_node, value_node in node.value:
        key = loader.construct_object(key_node, deep=True)
        if not isinstance(key, str):
            raise yaml.constructor.ConstructorError(
                None, None, f"key {show(key)} is not a name: every key is text", key_node.start_mark)
        if key in mapping:
            raise yaml.constructor.ConstructorError(
                None, None, f"key '{key}' appears twice", key_node.start_mark)
        mapping[key] = loader.construct_object(value_node, deep=True)
        mapping.key_lines[key] = key_node.start_mark.line + 1
    return mapping


_Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)
_FLOAT_12 = re.compile(r"^[-+]?(?:\d[\d_]*)?(?:\.\d*)?(?:[eE][-+]?\d+)$")
_Loader.add_implicit_resolver("tag:yaml.org,2002:float", _FLOAT_12, list("-+0123456789."))

def load_yaml(path: str | Path) -> Any:
    """Parse a YAML file; a missing file or bad syntax is a UserError naming the line."""
    return parse_yaml(read_text(path), Path(path))


def parse_yaml(text: str, path: str | Path) -> Any:
    """Parse YAML text as load_yaml does; `path` names it in errors. Every error is one line."""
    try:
        return yaml.load(text, Loader=_Loader)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = mark.line + 1 if mark else None
        raise UserError(f"{where(path, line)}: {_one_line(exc.problem or exc.context)}") from None
    except yaml.reader.ReaderError as exc:
        line = text[: exc.position].count("\n") + 1
        character = chr(exc.character) if isinstance(exc.character, int) else exc.character
        raise UserError(f"{where(path, line)}: the character {show(character)} is not allowed in YAML "
                        f"({_one_line(exc.reason)})") from None
    except yaml.YAMLError as exc:
        raise UserError(f"{path}: not valid YAML: {_one_line(exc)}") from None
    except RecursionError:
        raise UserError(f"{path}: not valid YAML: nested too deeply") from None


def dump_yaml(data: dict[str, Any]) -> str:
    """Block-style YAML with keys in the order given."""
    return yaml.safe_dump(_plain(data), sort_keys=False, default_flow_style=False)


def _plain(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if hasattr(value, "item"):  # numpy scalars
        return value.item()
    return value

