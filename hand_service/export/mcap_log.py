"""A recording as an MCAP file (the log format Foxglove Studio and ROS 2 read), JSON
messages with JSON-schema channels.

One channel per finger, `/hand/<finger>`, one message per row: `t` and that finger's
quantities without their suffix (`angle_deg`, `pressure_kpa`, ...), so every finger's
channel has the same schema (`hand_service.FingerSample`) and a plot in Foxglove reads
`/hand/index.angle_deg`, `/hand/thumb.angle_deg` alike. The columns of no finger (`t`,
`state`, or every column of a one-finger recording) go on `/hand`. A message per finger
rather than one per row of every column: a row of a five-finger recording has 52 fields,
and Foxglove's topic list and plot paths stay short and the same for every finger.

Each channel's metadata holds `units` (JSON: field -> unit) and `columns` (JSON: field ->
the CSV column it came from), and `finger` on a finger's channel; the CSV's `# key: value`
lines are the file's metadata record `recording`. A message's log and publish time is the
recording's `# started:` time (when present and readable, else 0) plus `t`, in ns. NaN and
infinity are written as null (JSON has no NaN).

    from mcap.reader import make_reader
    for schema, channel, message in make_reader(open("run.mcap", "rb")).iter_messages():
        ...
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import Any

import numpy as np

from hand_service.errors import UserError
from hand_service.export.table import Table
from hand_service.export.units import TIME_COLUMN, quantity

HAND_TOPIC = "/hand"
FINGER_SCHEMA = "hand_service.FingerSample"
HAND_SCHEMA = "hand_service.HandSample"
METADATA_NAME = "recording"


def start_ns(metadata: dict[str, str]) -> int:
    """The `# started:` time of a daemon recording in ns since the epoch, else 0."""
    text = metadata.get("started", "")
    try:
        return int(datetime.strptime(text, "%Y-%m-%dT%H:%M:%S%z").timestamp()) * 1_000_000_000
    except ValueError:
        return 0


def _json_type(values: np.ndarray | list[str]) -> dict[str, Any]:
    if not isinstance(values, np.ndarray):
        return {"type": "string"}
    if values.dtype.kind == "i":
        return {"type": "integer"}
    return {"type": ["number", "null"]}


def _cells(values: np.ndarray | list[str]) -> list[Any]:
    if not isinstance(values, np.ndarray):
        return list(values)
    if values.dtype.kind == "i":
        return [int(v) for v in values]
    return [float(v) if math.isfinite(v) else None for v in values.tolist()]


class _Channel:
    """One topic: its fields (message key -> CSV column) and their units."""

    def __init__(self, topic: str, finger: str | None) -> None:
        self.topic, self.finger = topic, finger
        self.fields: dict[str, str] = {}

    def schema(self, table: Table) -> dict[str, Any]:
        return {
            "title": FINGER_SCHEMA if self.finger else HAND_SCHEMA,
            "type": "object",
            "properties": {key: {**_json_type(table.columns[column]),
                                 "description": table.units[column] or "no unit",
                                 "unit": table.units[column]}
                           for key, column in self.fields.items()},
        }


def _channels(table: Table) -> list[_Channel]:
    hand = _Channel(HAND_TOPIC, None)
    fingers = {f: _Channel(f"{HAND_TOPIC}/{f}", f) for f in table.fingers}
    for column in table.columns:
        base, finger = quantity(column, table.fingers)
        (fingers[finger] if finger is not None else hand).fields[base] = column
    for channel in fingers.values():
        channel.fields = {TIME_COLUMN: TIME_COLUMN, **channel.fields}
    return [hand, *fingers.values()]


@dataclass(frozen=True)
class ChannelSpec:
    """A channel as the MCAP export and the live Foxglove server (view/foxglove.py) both
    declare it: its topic, schema (name, JSON schema text) and metadata."""

    topic: str
    schema_name: str
    schema_json: str
    metadata: dict[str, str]
    fields: dict[str, str]  # message key -> the CSV column

    def message(self, cells: dict[str, list[Any]], row: int) -> dict[str, Any]:
        return {key: cells[column][row] for key, column in self.fields.items()}


def channel_specs(table: Table) -> list[ChannelSpec]:
    """The channels of a recording's columns (those with at least one field)."""
    specs = []
    for channel in _channels(table):
        if not channel.fields:
            continue
        schema = channel.schema(table)
        metadata = {"units": json.dumps({k: table.units[c] for k, c in channel.fields.items()}),
                    "columns": json.dumps(channel.fields)}
        if channel.finger is not None:
            metadata["finger"] = channel.finger
        specs.append(ChannelSpec(channel.topic, schema["title"], json.dumps(schema, sort_keys=True), metadata,
                                 dict(channel.fields)))
    return specs


def table_cells(table: Table) -> dict[str, list[Any]]:
    """Every column as JSON cells (NaN and infinity as null)."""
    return {column: _cells(values) for column, values in table.columns.items()}


def write_mcap(table: Table, out: Path, software: str) -> Path:
    from hand_service.export.optional import need

    writer_module = need("mcap.writer")
    if TIME_COLUMN not in table.columns or not table.numeric(TIME_COLUMN):
        raise UserError(f"{table.path}: MCAP messages need a time: the recording has no numeric "
                        f"'{TIME_COLUMN}' column")
    t_s = np.asarray(table.columns[TIME_COLUMN], dtype=np.float64)
    if not np.all(np.isfinite(t_s)):
        raise UserError(f"{table.path}: the '{TIME_COLUMN}' column holds a non-finite time")
    log_ns = start_ns(table.metadata) + np.round(t_s * 1e9).astype(np.int64)
    if np.any(log_ns < 0):
        raise UserError(f"{table.path}: a negative time in '{TIME_COLUMN}' (MCAP times start at 0)")
    cells = table_cells(table)
    try:
        stream = open(out, "wb")  # noqa: SIM115 - closed below
    except OSError as exc:
        raise UserError(f"{out}: cannot write: {exc.strerror or exc}") from None
    with stream:
        writer = writer_module.Writer(stream)
        writer.start(profile="", library=software)
        ids: list[tuple[int, ChannelSpec]] = []
        schemas: dict[str, int] = {}
        for spec in channel_specs(table):
            if spec.schema_json not in schemas:
                schemas[spec.schema_json] = writer.register_schema(
                    name=spec.schema_name, encoding="jsonschema", data=spec.schema_json.encode())
            ids.append((writer.register_channel(topic=spec.topic, message_encoding="json",
                                                schema_id=schemas[spec.schema_json], metadata=spec.metadata),
                        spec))
        writer.add_metadata(METADATA_NAME, dict(table.metadata))
        for row in range(table.rows):
            time_ns = int(log_ns[row])
            for channel_id, spec in ids:
                message = spec.message(cells, row)
                writer.add_message(channel_id, log_time=time_ns, publish_time=time_ns, sequence=row,
                                   data=json.dumps(message, separators=(",", ":")).encode())
        writer.finish()
    return out
