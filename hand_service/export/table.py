"""A recording CSV as a table of every column, with units, for the exporters.

The file is read under the contract every recording reader keeps (docs/formats.md §1.1,
`hand_service.recording.read_recording`): comments and `# key: value` metadata anywhere,
the header first, every row as long as the header, a last line cut short by a killed
writer dropped with a warning, and a `t` column of finite numbers that strictly increase.
Unlike `read_recording`, which picks one finger and checks the columns a tool needs, this
keeps every column of the file in its order, and says what each column must hold
(docs/formats.md §1.5):

- `t`, every column whose name carries a unit (`*_kpa`, `*_deg`, ...) and `flags*` are
  numbers (NaN and infinity are numbers; `t` must be finite): a cell that is not is an
  error naming its line and column;
- `state`, `mode` and `finger` (with or without a `_<finger>` suffix) are text;
- any other column is numbers if every cell is one, else text, with a warning naming it.

Numbers are float64, or int64 when every cell is an integer (as `flags_<f>` is).
"""

from __future__ import annotations

import logging
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from hand_service.config.textfile import cell_text
from hand_service.errors import UserError, where
from hand_service.export.units import TIME_COLUMN, quantity, unit_of

# the reader's own rule for a last line cut short, so that export and every tool agree
from hand_service.recording import fingers_in, split_lines

log = logging.getLogger(__name__)

_INTEGER = re.compile(r"[+-]?\d+\Z")
TEXT_QUANTITIES = ("state", "mode", "finger")  # columns of text by definition (docs/formats.md §1.3)
INTEGER_QUANTITIES = ("flags",)  # numbers with no unit


@dataclass
class Table:
    """Every column of a recording: `columns` in the file's order, `units` by column name;
    `guessed_text`: the columns kept as text that the contract does not name as text."""

    path: Path
    columns: dict[str, np.ndarray | list[str]]
    units: dict[str, str]
    metadata: dict[str, str] = field(default_factory=dict)
    fingers: list[str] = field(default_factory=list)
    guessed_text: list[str] = field(default_factory=list)

    @property
    def rows(self) -> int:
        return len(next(iter(self.columns.values()))) if self.columns else 0

    def numeric(self, name: str) -> bool:
        return isinstance(self.columns[name], np.ndarray)


def _numbers(cells: list[str]) -> np.ndarray | int:
    """The cells as int64 or float64, or the index of the first cell that is not a number."""
    if cells and all(_INTEGER.match(c) for c in cells):
        return np.array([int(c) for c in cells], dtype=np.int64)
    values = np.empty(len(cells), dtype=np.float64)
    for i, cell in enumerate(cells):
        try:
            values[i] = float(cell)
        except ValueError:
            return i
    return values


def _kind(name: str, fingers: list[str]) -> str:
    """"number", "text" or "either" (decided by the cells), by the column's name."""
    base, _ = quantity(name, fingers)
    stem = base.split("_", 1)[0]  # `flags_index` in a file that has no `angle_deg_index`
    if name == TIME_COLUMN or unit_of(name, fingers) or stem in INTEGER_QUANTITIES:
        return "number"
    return "text" if stem in TEXT_QUANTITIES else "either"


def _check_time(path: Path, t_s: np.ndarray, row_lines: list[int]) -> None:
    bad = np.flatnonzero(~np.isfinite(t_s))
    if bad.size:
        raise UserError(f"{where(path, row_lines[bad[0]], TIME_COLUMN)}: {t_s[bad[0]]} where a finite "
                        "time is required")
    steps = np.flatnonzero(np.diff(t_s) <= 0)
    if steps.size:
        k = steps[0] + 1
        raise UserError(f"{where(path, row_lines[k], TIME_COLUMN)}: t = {t_s[k]:g} does not increase "
                        f"(previous {t_s[k - 1]:g})")


def _rows(path: Path) -> tuple[list[str], int, list[list[str]], list[int], dict[str, str]]:
    lines = split_lines(path)  # the recording reader's own splitting (comments, a truncated last line)
    if lines.header is None:
        raise UserError(f"{path}: no header line: not a recording (docs/formats.md §1)")
    lines.check_fields(path)
    return lines.header, lines.header_line, lines.rows, lines.row_lines, lines.metadata


def read_table(path: str | Path) -> Table:
    """Every column of a recording (docs/formats.md §1, §1.5); bad input is a UserError
    naming the file, the line and the column."""
    path = Path(path)
    header, header_line, rows, row_lines, metadata = _rows(path)
    seen: set[str] = set()
    for name in header:
        if not name:
            raise UserError(f"{where(path, header_line)}: an empty column name")
        if name in seen:
            raise UserError(f"{where(path, header_line)}: the column '{cell_text(name)}' appears twice")
        seen.add(name)
    if TIME_COLUMN not in seen:
        raise UserError(f"{where(path, header_line)}: no '{TIME_COLUMN}' column: export takes a recording "
                        f"with a time column (docs/formats.md §1.5)")
    if not rows:
        raise UserError(f"{path}: no rows after the header")
    fingers = fingers_in(header)
    columns: dict[str, np.ndarray | list[str]] = {}
    guessed: list[str] = []  # the text columns the contract does not name as text
    where_text: list[str] = []  # and their first cell that is not a number
    for i, name in enumerate(header):
        cells = [r[i] for r in rows]
        kind = _kind(name, fingers)
        values = _numbers(cells) if kind != "text" else 0
        if kind == "text":
            columns[name] = cells
        elif isinstance(values, np.ndarray):
            columns[name] = values
        elif kind == "number":
            raise UserError(f"{where(path, row_lines[values], name)}: not a number: "
                            f"'{cell_text(cells[values])}'")
        else:
            columns[name] = cells
            guessed.append(name)
            where_text.append(f"'{cell_text(name)}' (line {row_lines[values]}: '{cell_text(cells[values])}')")
    _check_time(path, np.asarray(columns[TIME_COLUMN], dtype=np.float64), row_lines)
    if guessed:
        log.warning("%s: not numbers, written as text: %s", path, ", ".join(where_text))
    units = {name: unit_of(name, fingers) for name in header}
    return Table(path=path, columns=columns, units=units, metadata=metadata, fingers=fingers,
                 guessed_text=guessed)
