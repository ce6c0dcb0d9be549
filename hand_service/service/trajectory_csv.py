"""Trajectory files for the control API (docs/trajectory.md).

    # any comment
    t,angle_ref_deg_index,force_ref_n_thumb
    0.00,0,
    0.01,0.5,

`t` (s, increasing) and per finger `angle_ref_deg_<finger>` (position mode) and/or
`force_ref_n_<finger>` (force mode). In each row a finger has at most one of its two
cells filled: that picks its mode from that row on; both empty vents it. Between rows of
the same mode the reference is interpolated linearly onto the control rate; a mode
holds until the next row. Every value is checked against the profile's target ranges.
"""

from __future__ import annotations

import csv
import math
import os
import stat
from array import array
from pathlib import Path
from typing import TextIO

import numpy as np

from hand_service.config.csvdialect import detect_dialect
from hand_service.config.profile import Profile
from hand_service.config.textfile import cell_text, printable
from hand_service.errors import UserError, where
from hand_service.service.trajectory import Trajectory
from rtcore import MODE_FORCE, MODE_POSITION, MODE_VENT

QUANTITIES = {"angle_ref_deg": MODE_POSITION, "force_ref_n": MODE_FORCE}
MAX_TICKS = 360_000  # one hour at 100 Hz
# Rows are checked while parsing, so a file never grows memory past this (the daemon locks
# its memory): rows closer than a tick add nothing the tick grid keeps.
MAX_ROWS = MAX_TICKS


def _ticks(duration_s: float, rate_hz: float) -> int:
    return math.floor(duration_s * rate_hz + 1e-9) + 1


def _columns(header: list[str], profile: Profile, path: Path, line: int) -> dict[str, dict[int, int]]:
    """quantity -> {finger index: column index}, refusing any column it does not know."""
    found: dict[str, dict[int, int]] = {q: {} for q in QUANTITIES}
    names = profile.finger_names
    for col, name in enumerate(header):
        if name == "t":
            continue
        quantity = next((q for q in QUANTITIES if name.startswith(q + "_")), None)
        finger = name[len(quantity) + 1:] if quantity else None
        if quantity is None or finger not in names:
            expected = (f"finger '{cell_text(finger or '')}' is not in the profile ({', '.join(names)})"
                        if quantity else "expected t, angle_ref_deg_<finger> or force_ref_n_<finger>")
            raise UserError(f"{where(path, line, cell_text(name))}: unknown column: {expected}")
        found[quantity][names.index(finger)] = col
    if "t" not in header:
        raise UserError(f"{where(path, line)}: missing required column 't'")
    if not any(found.values()):
        raise UserError(f"{where(path, line)}: no angle_ref_deg_<finger> or force_ref_n_<finger> column")
    return found


def _check(value: float, quantity: str, profile: Profile, path: Path, line: int, column: str) -> None:
    safety = profile.safety
    if quantity == "angle_ref_deg":
        low, high, unit = safety["target_angle_min_deg"], safety["target_angle_max_deg"], "deg"
    else:
        low, high, unit = safety["target_force_min_n"], safety["target_force_max_n"], "N"
    if not low <= value <= high:
        raise UserError(f"{where(path, line, column)}: {value:g} {unit} is outside the profile's "
                        f"target range [{low:g}, {high:g}] {unit}")


def _open_regular(path: Path) -> TextIO:
    """Open for reading only a regular file. A device is never opened (opening some has
    effects: a watchdog arms, a tty resets a board or becomes the daemon's controlling
    terminal), and the type is checked again on the open descriptor, which is opened
    without blocking: a FIFO swapped in between would otherwise hold the loader for good."""
    try:
        mode = os.stat(path).st_mode
    except ValueError as exc:  # a NUL in the path
        raise UserError(f"{printable(str(path))}: not a usable path: {exc}") from None
    if not stat.S_ISREG(mode):
        raise UserError(f"{path} is not a regular file (a FIFO, device or directory is never read)")
    # UTF-8, a byte-order mark dropped; csv takes CRLF, LF and CR line ends alike
    f = open(path, newline="", encoding="utf-8-sig",  # noqa: SIM115 - returned open, closed here on error
             opener=lambda p, flags: os.open(p, flags | os.O_NONBLOCK | os.O_NOCTTY))
    try:
        if not stat.S_ISREG(os.fstat(f.fileno()).st_mode):
            raise UserError(f"{path} is not a regular file (it changed while being opened)")
        os.set_blocking(f.fileno(), True)
    except BaseException:
        f.close()
        raise
    return f


def read_trajectory(path: str | Path, profile: Profile, rate_hz: float | None = None) -> Trajectory:
    """Read, validate and resample a trajectory file onto the control rate.

    Rows are parsed one at a time into flat arrays, so an hour of trajectory never holds
    millions of Python objects: the daemon parses it in a worker thread, and a bulk
    allocation or deallocation would hold the GIL away from the tick for 100 ms or more
    (and feed the young generations the loop's slack collects)."""
    path = Path(path)
    rate_hz = rate_hz or profile.control.rate_hz
    n_fingers = len(profile.fingers)
    t_s, cells_flat, modes_flat = array("d"), array("d"), array("i")
    header: list[str] | None = None
    try:
        with _open_regular(path) as f:
            dialect = detect_dialect(f.read(1 << 16).splitlines())  # a spreadsheet's `;`, decimal commas
            f.seek(0)
            for line, cells in enumerate(csv.reader(f, delimiter=dialect.separator), start=1):
                row = dialect.numbers(cells)
                if not row or row[0].lstrip().startswith("#") or (line == 1 and dialect.sep_line):
                    continue
                if header is None:
                    header = [c.strip() for c in row]
                    columns = _columns(header, profile, path, line)
                    t_col = header.index("t")
                    continue
                _row(row, line, header, columns, t_col, profile, path, t_s, cells_flat, modes_flat)
                _within_limits(t_s, rate_hz, path, line)
    except OSError as exc:
        raise UserError(f"{path}: cannot read: {exc.strerror or exc}") from None
    except UnicodeDecodeError as exc:
        raise UserError(f"{path}: not UTF-8 text (byte 0x{exc.object[exc.start]:02x}): save the file "
                        "as UTF-8") from None
    except csv.Error as exc:
        raise UserError(f"{path}: not a CSV text file ({' '.join(str(exc).split())})") from None
    if header is None or len(t_s) < 2:
        raise UserError(f"{path}: a trajectory needs a header and at least two rows")
    t = np.frombuffer(t_s, dtype=np.float64)
    n_rows = len(t)
    cells = np.frombuffer(cells_flat, dtype=np.float64).reshape(n_rows, len(QUANTITIES), n_fingers)
    values = {q: cells[:, k, :] for k, q in enumerate(QUANTITIES)}
    modes = np.frombuffer(modes_flat, dtype=np.int32).reshape(n_rows, n_fingers).copy()
    driven = np.array([any(f in c for c in columns.values()) for f in range(n_fingers)])
    modes[:, driven] = np.where(modes[:, driven] == -1, MODE_VENT, modes[:, driven])
    return _resample(t - t[0], modes, values, driven, rate_hz, _ticks(t[-1] - t[0], rate_hz), str(path))


def _within_limits(t_s: array, rate_hz: float, path: Path, line: int) -> None:
    """Stop at the first row past MAX_TICKS of duration or past MAX_ROWS rows."""
    duration_s = t_s[-1] - t_s[0]  # infinite for t from -1e308 to 1e308
    n_ticks: float = _ticks(duration_s, rate_hz) if math.isfinite(duration_s * rate_hz) else math.inf
    if n_ticks > MAX_TICKS:
        raise UserError(f"{where(path, line, 't')}: {t_s[-1] - t_s[0]:g} s at {rate_hz:g} Hz is "
                        f"{n_ticks} ticks; the limit is {MAX_TICKS} ticks")
    if len(t_s) > MAX_ROWS:
        raise UserError(f"{where(path, line)}: more than {MAX_ROWS} rows; the limit is {MAX_ROWS} "
                        "rows (no more than one per tick is used: resample the file)")


def _row(cells: list[str], line: int, header: list[str], columns: dict[str, dict[int, int]], t_col: int,
         profile: Profile, path: Path, t_s: array, values: array, modes: array) -> None:
    """One data row appended to the flat arrays: t, then per quantity a value per finger
    (NaN where empty), then a mode per finger (-1 where none)."""
    if len(cells) != len(header):
        raise UserError(f"{where(path, line)}: {len(cells)} fields where the header has {len(header)}")
    t = _number(cells[t_col], path, line, "t", required=True)
    if t_s and t <= t_s[-1]:
        raise UserError(f"{where(path, line, 't')}: t = {t:g} does not increase (previous {t_s[-1]:g})")
    t_s.append(t)
    n_fingers = len(profile.fingers)
    row_modes = [-1] * n_fingers
    for quantity, fingers in columns.items():
        row_values = [math.nan] * n_fingers
        for finger, col in fingers.items():
            value = _number(cells[col], path, line, header[col])
            if math.isnan(value):
                continue
            _check(value, quantity, profile, path, line, header[col])
            if row_modes[finger] != -1:
                raise UserError(f"{where(path, line, header[col])}: finger "
                                f"'{profile.finger_names[finger]}' has both an angle and a "
                                "force reference in one row; give one")
            row_modes[finger] = QUANTITIES[quantity]
            row_values[finger] = value
        values.extend(row_values)
    modes.extend(row_modes)


def _number(cell: str, path: Path, line: int, column: str, required: bool = False) -> float:
    cell = cell.strip()
    if not cell and not required:
        return math.nan
    try:
        value = float(cell)
    except ValueError:
        raise UserError(f"{where(path, line, column)}: not a number: {cell!r}") from None
    if not math.isfinite(value):
        raise UserError(f"{where(path, line, column)}: {cell!r} where a finite number is required")
    return value


def _resample(t: np.ndarray, modes: np.ndarray, values: dict[str, np.ndarray], driven: np.ndarray,
              rate_hz: float, n_ticks: int, source: str) -> Trajectory:
    """Onto the tick grid: the mode of the last row at or before each tick; the value
    interpolated when the next row has the same mode, else held."""
    traj = Trajectory.empty(n_ticks, modes.shape[1], rate_hz, source)
    t_tick = np.arange(n_ticks) / rate_hz
    j = np.clip(np.searchsorted(t, t_tick, side="right") - 1, 0, len(t) - 1)
    j1 = np.minimum(j + 1, len(t) - 1)
    span = np.where(j1 > j, t[j1] - t[j], 1.0)
    frac = np.where(j1 > j, (t_tick - t[j]) / span, 0.0)[:, None]
    same = modes[j1] == modes[j]
    for quantity, target in (("angle_ref_deg", traj.angle_deg), ("force_ref_n", traj.force_n)):
        v = values[quantity]
        target[:] = np.where(same, v[j] + frac * (v[j1] - v[j]), v[j])
    traj.mode[:, driven] = modes[j][:, driven]
    traj.derive()
    return traj
