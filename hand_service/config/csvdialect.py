"""The dialect of a CSV a person saved: the separator between fields and the decimal mark.

The project writes `,` between fields and `.` as the decimal mark. A spreadsheet in a
locale whose decimal mark is a comma (Excel in most of Europe) saves `;` between fields
and `0,5` for a half, often behind a UTF-8 byte-order mark (read_text drops it) and a
first line `sep=;`. Such a file is read as it is; one whose decimal commas fall between
comma-separated fields cannot be split and is refused with that cause.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from dataclasses import dataclass

SEPARATORS = (",", ";", "\t")
_DECIMAL_COMMA = re.compile(r"^[+-]?(?:\d+,\d*|,\d+)(?:[eE][+-]?\d+)?$")
_WHOLE_NUMBER = re.compile(r"^[+-]?\d+(?:[eE][+-]?\d+)?$")
_SEP_LINE = re.compile(r"^sep=(.)$", re.IGNORECASE)


@dataclass(frozen=True)
class CsvDialect:
    """How a file's lines split into cells."""

    separator: str = ","
    sep_line: bool = False  # the file's first line is Excel's `sep=X`, not data

    @property
    def decimal_comma(self) -> bool:
        """Numbers may carry a decimal comma: only where the comma does not separate fields."""
        return self.separator != ","

    def cells(self, line: str) -> list[str]:
        """A line's cells, stripped, with a decimal comma made a point."""
        return self.numbers([c.strip() for c in line.split(self.separator)])

    def numbers(self, cells: list[str]) -> list[str]:
        """Cells (split by a csv reader, say) with a decimal comma made a point."""
        if not self.decimal_comma:
            return cells
        return [c.replace(",", ".") if _DECIMAL_COMMA.match(c.strip()) else c for c in cells]

    def metadata(self, line: str) -> str:
        """A `#` line without the empty cells a spreadsheet pads it with."""
        return line.rstrip(self.separator + " ")


def detect_dialect(lines: Iterable[str]) -> CsvDialect:
    """The dialect of a file from its first line that is not blank or a `#` comment (the
    header): `,` if it holds one, else `;` or a tab if it holds one. Excel's `sep=X` first
    line names the separator outright."""
    for number, raw in enumerate(lines):
        line = raw.strip()
        if not line:
            continue
        if number == 0 and (named := _SEP_LINE.match(line)):
            return CsvDialect(named.group(1), sep_line=True)
        if line.startswith("#"):
            continue
        return CsvDialect(next((s for s in SEPARATORS if s in line), ","))
    return CsvDialect()


def split_decimal_commas(cells: list[str], fields: int) -> bool:
    """True when a comma-separated row of more fields than the header's is all whole
    numbers: decimal commas taken for separators (`0,01,12,5` for 0.01 and 12.5)."""
    return len(cells) > fields and all(_WHOLE_NUMBER.match(c) for c in cells)


DECIMAL_COMMA_ADVICE = ("decimal commas in a comma-separated file? Save it with ';' between fields "
                        "(Excel's CSV in a decimal-comma locale) or with '.' as the decimal mark")
