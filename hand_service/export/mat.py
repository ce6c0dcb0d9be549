"""A recording as a MATLAB .mat file (scipy.io.savemat, MATLAB 5 format, which `load` reads
in every MATLAB since 5 and in Octave).

Each column is a variable of its own, a column vector (numbers as double, text as a cell
array of char), named as in the CSV; beside them:

- `units`: a struct, one field per column, the unit as text ('' for none);
- `metadata`: a struct of the CSV's `# key: value` lines, values as text;
- `columns`: a cell array of the column names in the CSV's order.

    load('run.mat'); plot(t, angle_deg_index); ylabel(units.angle_deg_index)
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np

from hand_service.errors import UserError
from hand_service.export.table import Table

RESERVED = ("units", "metadata", "columns")
_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,62}\Z")


def matlab_name(name: str) -> str:
    """A MATLAB variable or field name for `name`: other characters become `_`, a name
    that does not start with a letter gets an `x` in front, cut to 63 characters."""
    if _NAME.match(name):
        return name
    clean = re.sub(r"[^A-Za-z0-9_]", "_", name)
    if not clean[:1].isalpha():
        clean = "x" + clean
    return clean[:63]


def _names(table: Table) -> dict[str, str]:
    names: dict[str, str] = {}
    taken: dict[str, str] = {}
    for column in table.columns:
        name = matlab_name(column)
        if name in RESERVED:
            raise UserError(f"{table.path}: the column '{column}' would hide the .mat file's "
                            f"'{name}' variable; rename it")
        if name in taken:
            raise UserError(f"{table.path}: the columns '{taken[name]}' and '{column}' have the same "
                            f"MATLAB name '{name}'; rename one")
        names[column], taken[name] = name, column
    return names


def _cell(values: list[str]) -> np.ndarray:
    cell = np.empty((len(values), 1), dtype=object)
    for i, value in enumerate(values):
        cell[i, 0] = value
    return cell


def write_mat(table: Table, out: Path) -> Path:
    from scipy.io import savemat

    names = _names(table)
    variables: dict[str, Any] = {}
    for column, values in table.columns.items():
        if isinstance(values, np.ndarray):
            variables[names[column]] = values.astype(np.float64).reshape(-1, 1)
        else:
            variables[names[column]] = _cell(values)
    variables["units"] = {names[c]: table.units[c] for c in table.columns}
    metadata: dict[str, str] = {}
    for key, value in table.metadata.items():
        metadata.setdefault(matlab_name(key), value)
    variables["metadata"] = metadata
    variables["columns"] = _cell(list(table.columns))
    try:  # opened here: given a path it cannot open, savemat reports a misleading reader error
        stream = open(out, "wb")  # noqa: SIM115 - closed below
    except OSError as exc:
        raise UserError(f"{out}: cannot write: {exc.strerror or exc}") from None
    with stream:
        savemat(stream, variables, do_compression=True, oned_as="column")
    return out
