"""Recordings exported to the formats labs analyse in: MATLAB's .mat, Parquet, MCAP.

    export_recording(Path("run.csv"), "mat")    # -> run.mat beside it

Every column of the CSV goes out with its name and its unit (from the name,
`hand_service.export.units`) and the CSV's `# key: value` metadata. docs/formats.md §1.5.
"""

from __future__ import annotations

from pathlib import Path

from hand_service.errors import UserError

# light: `hand-service export --help` imports this module, not numpy nor the writers
FORMATS = {"mat": ".mat", "parquet": ".parquet", "mcap": ".mcap"}


def check_output(out: Path) -> None:
    """The output's folder must exist and be a folder: said in one line before any reading."""
    folder = out.parent
    if not folder.exists():
        raise UserError(f"{out}: cannot write: the folder {folder} does not exist")
    if not folder.is_dir():
        raise UserError(f"{out}: cannot write: {folder} is not a folder")


def export_recording(source: Path, to: str, out: Path | None = None, software: str = "hand-service") -> Path:
    """Write `source` (a recording CSV) in format `to`; `out` defaults to the source's name
    with the format's extension. Returns the path written."""
    from hand_service.export.mat import write_mat
    from hand_service.export.mcap_log import write_mcap
    from hand_service.export.parquet import write_parquet
    from hand_service.export.table import read_table

    out = out if out is not None else source.with_suffix(FORMATS[to])
    check_output(out)
    table = read_table(source)
    if to == "mat":
        return write_mat(table, out)
    if to == "parquet":
        return write_parquet(table, out, software)
    return write_mcap(table, out, software)


__all__ = ["FORMATS", "check_output", "export_recording"]
