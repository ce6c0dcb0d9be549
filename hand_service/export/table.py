"""A recording CSV as a table of every column, with units, for the exporters.

Unlike `hand_service.recording.read_recording`, which picks one finger and checks the
columns a tool needs, this keeps every column of the file as it is: numbers as float64
(or int64 when every cell is an integer, as `flags_<f>` is), other columns as text, in
the file's order; and the `# key: value` metadata.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from hand_service.config.textfile import cell_text, read_text
from hand_service.errors import UserError, where
from hand_service.export.units import unit_of
from hand_service.recording import fingers_in

_INTEGER = re.compile(r"[+-]?\d+\Z")


@dataclass
class Table:
    """Every column of a recording: `columns` in the file's order, `units` by column name."""

    path: Path
    columns: dict[str, np.ndarray | list[str]]
    units: dict[str, str]
    metadata: dict[str, str] = field(default_factory=dict)
    fingers: list[str] = field(default_factory=list)

    @property
    def rows(self) -> int:
        return len(next(iter(self.columns.values()))) if self.columns else 0

    def numeric(self, name: str) -> bool:
        return isinstance(self.columns[name], np.ndarray)


def _metadata(line: str, metadata: dict[str, str]) -> None:
    body = line[1:].strip()
    key, colon, value = body.partition(":")
    if colon and key.strip() and " " not in key.strip():
        metadata[key.strip()] = value.strip()


def _column(cells: list[str]) -> np.ndarray | list[str]:
    if cells and all(_INTEGER.match(c) for c in cells):
        return np.array([int(c) for c in cells], dtype=np.int64)
    try:
        return np.array([float(c) for c in cells], dtype=np.float64)
    except ValueError:
        return cells


def read_table(path: str | Path) -> Table:
    """Every column of a recording (docs/formats.md §1); bad input is a UserError naming
    the line."""
    path = Path(path)
    text = read_text(path)
    header: list[str] | None = None
    header_line = 0
    metadata: dict[str, str] = {}
    rows: list[list[str]] = []
    for number, raw in enumerate(text.split("\n"), start=1):
        line = raw.strip()
        if not line:
            continue
        if line.startswith("#"):
            _metadata(line, metadata)
            continue
        cells = [c.strip() for c in line.split(",")]
        if header is None:
            header, header_line = cells, number
            continue
        if len(cells) != len(header):
            raise UserError(f"{where(path, number)}: {len(cells)} fields where the header has {len(header)}")
        rows.append(cells)
    if header is None:
        raise UserError(f"{path}: no header line: not a recording (docs/formats.md §1)")
    seen: set[str] = set()
    for name in header:
        if not name:
            raise UserError(f"{where(path, header_line)}: an empty column name")
        if name in seen:
            raise UserError(f"{where(path, header_line)}: the column '{cell_text(name)}' appears twice")
        seen.add(name)
    if not rows:
        raise UserError(f"{path}: no rows after the header")
    fingers = fingers_in(header)
    columns = {name: _column([r[i] for r in rows]) for i, name in enumerate(header)}
    units = {name: unit_of(name, fingers) for name in header}
    return Table(path=path, columns=columns, units=units, metadata=metadata, fingers=fingers)
