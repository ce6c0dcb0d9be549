"""A recording as an Apache Parquet file (pyarrow), for pandas, polars, DuckDB, Spark, R.

One column per CSV column, in its order: float64 (NaN kept), int64 for integer columns
(`flags_<f>`), text as strings. Each field's metadata holds its unit under `unit` ("" for
none); the schema's metadata holds the CSV's `# key: value` lines, as JSON under
`hand_service.metadata`, and the software that wrote it under `hand_service.export`.

    import pandas as pd; df = pd.read_parquet("run.parquet")
    import pyarrow.parquet as pq; pq.read_schema("run.parquet").field("angle_deg_index").metadata
"""

from __future__ import annotations

import json
from pathlib import Path

from hand_service.errors import UserError
from hand_service.export.table import Table

METADATA_KEY = b"hand_service.metadata"
UNIT_KEY = b"unit"


def write_parquet(table: Table, out: Path, software: str) -> Path:
    from hand_service.export.optional import need

    pa = need("pyarrow")
    pq = need("pyarrow.parquet")
    fields, arrays = [], []
    for name, values in table.columns.items():
        array = pa.array(values)
        fields.append(pa.field(name, array.type, metadata={UNIT_KEY: table.units[name].encode()}))
        arrays.append(array)
    schema = pa.schema(fields, metadata={METADATA_KEY: json.dumps(table.metadata).encode(),
                                         b"hand_service.export": software.encode()})
    try:
        pq.write_table(pa.Table.from_arrays(arrays, schema=schema), out)
    except OSError as exc:
        raise UserError(f"{out}: cannot write: {exc}") from None
    return out
