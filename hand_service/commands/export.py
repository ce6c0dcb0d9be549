"""`hand-service export`: a recording CSV as .mat (MATLAB), Parquet or MCAP (Foxglove)."""

from __future__ import annotations

import argparse
from pathlib import Path

HELP = "convert a recording CSV to .mat (MATLAB), Parquet (pandas, R) or MCAP (Foxglove, ROS 2)"
DESCRIPTION = """\
Write a recording (any CSV of docs/formats.md §1: the daemon's, trials', simulate's) in
another format, every column with its unit and the file's `# key: value` metadata:

  mat      MATLAB: one variable per column, a `units` struct, a `metadata` struct
           (scipy.io.savemat; `load('run.mat')` in MATLAB or Octave)
  parquet  Apache Parquet: the unit in each field's metadata (pyarrow;
           `pandas.read_parquet('run.parquet')`)
  mcap     MCAP, JSON messages: a channel per finger, /hand/<finger>, one message per row,
           and /hand for t and state (the mcap package; Foxglove Studio opens it)

The recording must have a `t` column of finite, increasing times. Columns whose name
carries a unit (angle_deg, pressure_kpa, ...) and flags are numbers: a cell that is not
is refused, naming its line. state, mode and finger are text; any other column with a
cell that is not a number is written as text, with a warning naming it.

Parquet and MCAP need the optional packages: pip install 'hand-service[export]'.
The output is the recording's name with the format's extension unless -o says otherwise;
an existing file is replaced only with --force. Details: docs/formats.md §1.5.

examples:
  hand-service export run.csv --to mat
  hand-service export run.csv --to parquet -o /data/run.parquet
  hand-service export run.csv --to mcap --force
"""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from hand_service.export import FORMATS

    parser.add_argument("recording", type=Path, metavar="REC.csv", help="the recording to convert")
    parser.add_argument("--to", required=True, choices=sorted(FORMATS), help="the format to write")
    parser.add_argument("-o", "--output", type=Path, metavar="OUT",
                        help="the file to write (default: REC with the format's extension)")
    parser.add_argument("--force", action="store_true", help="replace OUT if it exists")


def main(args: argparse.Namespace) -> int:
    from hand_service.errors import UserError
    from hand_service.export import FORMATS, check_output, export_recording
    from hand_service.version import software_version

    source: Path = args.recording
    if not source.is_file():
        raise UserError(f"{source}: no such recording")
    out: Path = args.output if args.output is not None else source.with_suffix(FORMATS[args.to])
    check_output(out)
    if out.resolve() == source.resolve():
        raise UserError(f"{out}: the output would replace the recording itself; give another -o")
    if out.exists() and not args.force:
        raise UserError(f"{out}: exists already; give --force to replace it, or another -o")
    written = export_recording(source, args.to, out, software=f"hand-service {software_version()}")
    print(f"wrote {written}")
    return 0
