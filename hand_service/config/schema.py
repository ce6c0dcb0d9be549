"""Declarative checks for YAML sections: each key's kind, unit, range, default and doc.

The same declarations validate files (errors name the file, line and key, and suggest
the nearest known key for a typo) and generate the key reference in docs/.
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hand_service.config.textfile import show
from hand_service.config.yamlio import LineDict
from hand_service.errors import UserError, where

REQUIRED: Any = object()


@dataclass(frozen=True)
class Key:
    name: str
    doc: str
    kind: str = "float"  # float | int | bool | str | choice | mapping
    unit: str = ""
    default: Any = REQUIRED
    min: float | None = None
    max: float | None = None
    min_exclusive: bool = False
    choices: tuple[str, ...] = ()  # a choice's values; an int's allowed values, as text

    @property
    def required(self) -> bool:
        return self.default is REQUIRED

    def describe_range(self) -> str:
        if self.kind == "choice":
            return " | ".join(self.choices)
        if self.choices:
            return " or ".join(self.choices)
        if self.kind == "bool":
            return "true | false"
        if self.min is None and self.max is None:
            return ""
        low = "" if self.min is None else f"{self.min:g} {'<' if self.min_exclusive else '≤'} "
        high = "" if self.max is None else f" ≤ {self.max:g}"
        return f"{low}x{high}"

    def describe_default(self) -> str:
        if self.required:
            return "required"
        return "—" if self.default is None else str(self.default).lower() if self.kind == "bool" else str(
            self.default)


@dataclass(frozen=True)
class Section:
    title: str
    doc: str
    keys: tuple[Key, ...]

    def by_name(self) -> dict[str, Key]:
        return {k.name: k for k in self.keys}


def fail(source: str | Path, mapping: Any, key: str | None, message: str) -> UserError:
    line = mapping.line_of(key) if isinstance(mapping, LineDict) and key else getattr(mapping, "line", None)
    return UserError(f"{where(source, line)}: {message}")


def expect_mapping(value: Any, source: str | Path, parent: Any, key: str, context: str) -> LineDict:
    if not isinstance(value, dict):
        raise fail(source, parent, key, f"{context} must be a mapping of keys to values")
    if not isinstance(value, LineDict):
        value = LineDict(value)
    return value


def check_value(key: Key, value: Any, source: str | Path, mapping: Any, context: str) -> Any:
    label = f"{context}.{key.name}" if context else key.name
    unit = f" {key.unit}" if key.unit else ""
    if key.kind in ("float", "int"):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise fail(source, mapping, key.name, f"{label} must be a number{unit}, not {show(value)}")
        try:
            number = float(value)
        except OverflowError:  # an integer beyond any double
            raise fail(source, mapping, key.name, f"{label} = {show(value)} is out of range "
                       f"({key.describe_range() or 'beyond any number'})") from None
        if not math.isfinite(number):
            raise fail(source, mapping, key.name, f"{label} must be finite, not {show(value)}")
        if key.kind == "int" and not number.is_integer():
            raise fail(source, mapping, key.name, f"{label} must be a whole number, not {show(value)}")
        too_low = key.min is not None and (value <= key.min if key.min_exclusive else value < key.min)
        too_high = key.max is not None and value > key.max
        if too_low or too_high or (key.choices and str(int(number)) not in key.choices):
            raise fail(source, mapping, key.name,
                       f"{label} = {number:g}{unit} is out of range ({key.describe_range()})")
        return int(value) if key.kind == "int" else number
    if key.kind == "bool":
        if not isinstance(value, bool):
            raise fail(source, mapping, key.name, f"{label} must be true or false, not {show(value)}")
        return value
    if key.kind == "str":
        if not isinstance(value, str):
            raise fail(source, mapping, key.name, f"{label} must be text, not {show(value)}")
        return value
    if key.kind == "choice":
        if not isinstance(value, str) or value not in key.choices:
            raise fail(source, mapping, key.name,
                       f"{label} must be one of {', '.join(key.choices)}, not {show(value)}")
        return value
    if key.kind == "mapping":
        return expect_mapping(value, source, mapping, key.name, label)
    raise AssertionError(f"unknown kind {key.kind}")


def unknown_key_message(key: object, known: list[str], context: str) -> str:
    near = difflib.get_close_matches(str(key), known, n=1, cutoff=0.6)
    hint = f" (did you mean '{near[0]}'?)" if near else ""
    where_in = f" in {context}" if context else ""
    name = f"'{key}'" if isinstance(key, str) and key.isprintable() and len(key) <= 40 else show(key)
    return f"unknown key {name}{where_in}{hint}"


def validate(data: Any, section: Section, source: str | Path, context: str = "",
             extra: tuple[str, ...] = ()) -> dict[str, Any]:
    """Check a mapping against a section; returns the values with defaults filled in.

    Keys named in `extra` are allowed through unchecked for the caller to handle.
    """
    keys = section.by_name()
    if not isinstance(data, dict):
        raise UserError(f"{where(source, getattr(data, 'line', None))}: "
                        f"{context or 'the file'} must be a mapping of keys to values")
    for key in data:
        if key not in keys and key not in extra:
            raise fail(source, data, key, unknown_key_message(key, [*keys, *extra], context))
    values: dict[str, Any] = {}
    for key in section.keys:
        if key.name in data and data[key.name] is not None:
            values[key.name] = check_value(key, data[key.name], source, data, context)
        elif key.required:
            label = f"{context}.{key.name}" if context else key.name
            raise fail(source, data, None, f"missing required key '{label}' ({key.doc})")
        else:
            values[key.name] = key.default
    return values


def markdown_table(section: Section) -> str:
    rows = ["| key | unit | range | default | meaning |", "|---|---|---|---|---|"]
    for k in section.keys:
        rows.append(f"| `{k.name}` | {k.unit or '—'} | {k.describe_range() or '—'} | "
                    f"{k.describe_default()} | {k.doc} |")
    return "\n".join(rows)
