"""Recordings: the CSV of docs/formats.md, read and written.

    t,pressure_kpa,angle_deg
    # finger: index
    # sample_rate_hz: 100
    0.000,0.00,0.050

The header comes first and the `# key: value` metadata after it, so that
`numpy.genfromtxt(f, delimiter=",", names=True, comments="#")` (which takes its names from
the first line) and `pandas.read_csv(f, comment="#")` both read the file. Files with the
metadata above the header (written before) are read the same.

Required numeric columns are `t`, `pressure_kpa` and `angle_deg`; others are optional and
found by name. A multi-finger recording from the daemon suffixes every per-finger column
with `_<finger>`; `finger=` picks one and strips the suffix. Bad input is a UserError
naming the file, line and column.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from hand_service.config.csvdialect import DECIMAL_COMMA_ADVICE, detect_dialect, split_decimal_commas
from hand_service.config.textfile import cell_text, read_text
from hand_service.errors import UserError, where
from hand_service.export.units import unit_of

log = logging.getLogger(__name__)

REQUIRED = ("t", "pressure_kpa", "angle_deg")
MIN_DURATION_S = 1.0
# Bounds past any reading of the quantity, a thousand times and more beyond a real one: a
# cell past them is a corrupt or mis-scaled file, which would overflow the fits' squares.
LIMITS = {"t": (1e10, "s", "time of a recording (three centuries)"),
          "angle_deg": (1e6, "deg", "angle of a finger (2 800 turns)"),
          "pressure_kpa": (1e7, "kPa", "pressure (10 GPa)"),
          "pressure_meas_kpa": (1e7, "kPa", "pressure (10 GPa)")}


@dataclass
class Recording:
    path: Path
    t_s: np.ndarray
    pressure_kpa: np.ndarray
    angle_deg: np.ndarray
    columns: dict[str, np.ndarray] = field(default_factory=dict)
    text_columns: dict[str, list[str]] = field(default_factory=dict)
    metadata: dict[str, str] = field(default_factory=dict)
    finger: str | None = None

    @property
    def sample_rate_hz(self) -> float:
        """From the median interval, so small timing jitter does not matter."""
        return float(1.0 / np.median(np.diff(self.t_s)))

    @property
    def duration_s(self) -> float:
        return float(self.t_s[-1] - self.t_s[0])

    def optional(self, name: str) -> np.ndarray | None:
        """A numeric column if present and fully finite, else None."""
        values = self.columns.get(name)
        if values is None or not np.all(np.isfinite(values)):
            return None
        return values

    def __len__(self) -> int:
        return int(self.t_s.size)


def _parse_metadata(line: str, metadata: dict[str, str]) -> None:
    body = line[1:].strip()
    if ":" in body:
        key, value = body.split(":", 1)
        if key.strip() and " " not in key.strip():
            metadata[key.strip()] = value.strip()


def fingers_in(header: Iterable[str]) -> list[str]:
    """Finger suffixes of a daemon recording, from its `angle_deg_<finger>` columns."""
    return [name[len("angle_deg_"):] for name in header if name.startswith("angle_deg_")]


def _select_finger(header: list[str], finger: str | None, path: Path, header_line: int) -> list[str]:
    """Column names as the caller sees them: suffixed columns of `finger` lose their suffix."""
    fingers = fingers_in(header)
    if finger is None:
        if "angle_deg" not in header and fingers:
            raise UserError(f"{where(path, header_line)}: this recording holds several fingers "
                            f"({cell_text(', '.join(fingers), 200)}); pick one with --finger")
        return header
    if "angle_deg" in header and not fingers:
        return header  # a one-finger file: --finger only names it
    if finger not in fingers:
        known = cell_text(", ".join(fingers), 200) or "none"
        raise UserError(f"{where(path, header_line)}: no columns for finger '{finger}' (fingers: {known})")
    suffix = f"_{finger}"
    renamed = []
    for name in header:
        if name.endswith(suffix):
            renamed.append(name[: -len(suffix)])
        elif any(name.endswith(f"_{other}") for other in fingers):
            renamed.append(f"\0{name}")  # another finger's column: hidden
        else:
            renamed.append(name)
    return renamed


@dataclass
class CsvLines:
    """A recording file split into its parts, nothing converted yet."""

    header: list[str] | None  # None: the file has no header line
    header_line: int
    metadata: dict[str, str]  # the `# key: value` lines
    rows: list[list[str]]  # every data row's cells, stripped
    row_lines: list[int]  # each row's line number in the file

    def check_fields(self, path: Path) -> None:
        """Every row has as many fields as the header, or the first that does not is a
        UserError (naming decimal commas that split a comma-separated row)."""
        fields = len(self.header or ())
        for cells, number in zip(self.rows, self.row_lines, strict=True):
            if len(cells) != fields:
                cause = f": {DECIMAL_COMMA_ADVICE}" if split_decimal_commas(cells, fields) else ""
                raise UserError(f"{where(path, number)}: {len(cells)} fields where the header has "
                                f"{fields}{cause}")


def split_lines(path: Path) -> CsvLines:
    """The `#` metadata, the header and the data rows of a recording (docs/formats.md §1.1):
    comments anywhere, blank lines skipped, a truncated last line dropped with a warning.
    The one reader of the CSV's lines, for read_recording and export alike."""
    text = read_text(path)  # UTF-8, a byte-order mark dropped, CRLF and CR line ends made LF
    lines = text.split("\n")
    dialect = detect_dialect(lines)  # `;` and decimal commas from a spreadsheet, too
    out = CsvLines(None, 0, {}, [], [])
    for number, raw in enumerate(lines, start=1):
        line = raw.strip()
        if not line or (number == 1 and dialect.sep_line):
            continue
        if line.startswith("#"):
            _parse_metadata(dialect.metadata(line), out.metadata)
            continue
        cells = dialect.cells(line)
        if out.header is None:
            out.header, out.header_line = cells, number
            continue
        out.rows.append(cells)
        out.row_lines.append(number)
    rows = out.rows
    if (out.header is not None and rows and not text.endswith("\n")
            and _looks_truncated(rows[-1], rows[-2] if len(rows) > 1 else None, out.header)):
        log.warning("%s: dropped the truncated last line %d", path, out.row_lines[-1])
        rows.pop()
        out.row_lines.pop()
    return out


def read_recording(path: str | Path, finger: str | None = None, required: tuple[str, ...] = REQUIRED,
                   min_duration_s: float = MIN_DURATION_S) -> Recording:
    path = Path(path)
    lines = split_lines(path)
    header, header_line, rows, row_lines, metadata = (lines.header, lines.header_line, lines.rows,
                                                      lines.row_lines, lines.metadata)
    if header is None:
        raise UserError(f"{path}: no header line (expected columns {', '.join(required)})")
    if not rows:
        raise UserError(f"{where(path, header_line)}: a header and no data rows after it")
    names = _select_finger(header, finger, path, header_line)
    index: dict[str, int] = {}
    for i, name in enumerate(names):
        if name.startswith("\0"):
            continue
        if name in index:
            own = [k for k in (index[name], i) if header[k] != name]  # the finger's own column
            if len(own) != 1:
                raise UserError(f"{where(path, header_line)}: column '{header[i]}' appears twice in the "
                                f"header (fields {index[name] + 1} and {i + 1}): which one is meant?")
            index[name] = own[0]  # a finger's column before the one its fingers share
            continue
        index[name] = i
    for name in required:
        if name not in index:
            hint = ""
            if f"{name}_" in ",".join(header) and finger is None:
                hint = " (per-finger columns found: pick one with --finger)"
            raise UserError(f"{where(path, header_line)}: missing required column '{name}'{hint}")
    lines.check_fields(path)

    columns: dict[str, np.ndarray] = {}
    text_columns: dict[str, list[str]] = {}
    for name, i in index.items():
        cells = [r[i] for r in rows]
        try:
            columns[name] = np.array([float(c) for c in cells], dtype=np.float64)
        except ValueError:
            if name in required or unit_of(name):  # a measured quantity: a typo is an error
                bad = next(k for k, c in enumerate(cells) if not _is_float(c))
                raise UserError(f"{where(path, row_lines[bad], name)}: not a number: "
                                f"{cells[bad]!r}") from None
            text_columns[name] = cells
    for name in required:
        values = columns[name]
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise UserError(f"{where(path, row_lines[bad[0]], name)}: {cells_text(values[bad[0]])} "
                            "where a finite number is required")
    for name, (limit, unit, what) in LIMITS.items():
        values = columns.get(name)
        bad = np.flatnonzero(np.abs(values) > limit) if values is not None else []
        if len(bad):
            raise UserError(f"{where(path, row_lines[bad[0]], name)}: {values[bad[0]]:g} {unit} is past any "
                            f"{what}: a corrupt or mis-scaled file? (|{name}| <= {limit:g})")
    t = columns["t"] if "t" in columns else np.arange(len(rows), dtype=float)
    if "t" in required:
        steps = np.diff(t)
        bad = np.flatnonzero(steps <= 0)
        if bad.size:
            k = bad[0] + 1
            raise UserError(f"{where(path, row_lines[k], 't')}: t = {t[k]:g} does not increase "
                            f"(previous {t[k - 1]:g})")
    if "t" in required and (t.size < 2 or t[-1] - t[0] < min_duration_s):  # (pairs need no duration)
        span = t[-1] - t[0] if t.size >= 2 else 0.0
        raise UserError(f"{path}: only {span:.3g} s of data; at least {min_duration_s:g} s is needed")
    return Recording(path=path, t_s=t, pressure_kpa=columns.get("pressure_kpa", np.zeros_like(t)),
                     angle_deg=columns.get("angle_deg", np.zeros_like(t)), columns=columns,
                     text_columns=text_columns, metadata=metadata,
                     finger=finger or metadata.get("finger"))


def check_finger(recording: Recording, finger: str | None) -> None:
    """A recording whose `# finger:` line names another finger than the model's is a mistake
    (its inertia, gain and limits are another finger's)."""
    recorded = recording.metadata.get("finger")
    if finger is not None and recorded is not None and recorded != finger:
        raise UserError(f"{recording.path}: recorded from finger '{recorded}', but the model is "
                        f"finger '{finger}'")


def cells_text(value: float) -> str:
    return "NaN" if math.isnan(value) else str(value)


def _is_float(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return False
    return True


def _looks_truncated(last: list[str], previous: list[str] | None, header: list[str]) -> bool:
    """A writer killed mid-line leaves too few fields, an empty one, or a cut-off number."""
    if len(last) != len(header) or "" in last:
        return True
    if previous is None:
        return False
    return any(_is_float(p) and not _is_float(c) for p, c in zip(previous, last, strict=False))


def write_recording(path: str | Path, columns: Mapping[str, np.ndarray | list],
                    metadata: Mapping[str, object] | None = None, digits: int = 6) -> None:
    """Write a recording: the header, then `# key: value` lines, then the rows."""
    names = list(columns)
    n = len(next(iter(columns.values()))) if columns else 0
    out = [",".join(names)]
    out += [f"# {k}: {v}" for k, v in (metadata or {}).items()]
    formatted = []
    for name in names:
        values = columns[name]
        if isinstance(values, np.ndarray) and values.dtype.kind == "f":
            formatted.append([f"{v:.{digits}g}" for v in values])
        else:
            formatted.append([str(v) for v in values])
    out.extend(",".join(col[k] for col in formatted) for k in range(n))
    try:
        Path(path).write_text("\n".join(out) + "\n")
    except OSError as exc:
        raise UserError(f"{path}: cannot write: {exc.strerror or exc}") from None
