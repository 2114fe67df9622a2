"""A results store as flat tables: Parquet and CSV, one row per scenario.

The table is built from :meth:`scenarios.store.ResultStore.rows`; traces and
tracebacks stay in the store.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from scenarios.rows import ROW_TYPES
from scenarios.store import EXPORT_FORMATS, META_COLUMNS, ResultStore, StoreError


def export_store(
    store: ResultStore,
    stem: str | Path,
    formats: Sequence[str] = EXPORT_FORMATS,
    *,
    sweep: str | None = None,
    status: str | None = None,
) -> list[Path]:
    """Write a store's rows as a flat table to ``STEM.parquet`` and/or ``STEM.csv``.

    Columns: the metadata columns (``hash``, ``status``, ``error``,
    timings...), ``config.<dotted.path>`` for every scenario field and
    ``result.<name>`` for every result scalar. List-valued fields and
    columns whose values mix types (e.g. numbers and text) are written as
    JSON text, so both formats hold the same table. Traces and tracebacks
    stay in the store.

    Returns
    -------
    list of Path
        The files written.

    Raises
    ------
    StoreError
        Unknown format, sweep or status.
    """
    import pyarrow as pa
    import pyarrow.csv as pa_csv
    import pyarrow.parquet as pq

    bad = [f for f in formats if f not in EXPORT_FORMATS]
    if bad or not formats:
        raise StoreError(
            f"export formats must be among {EXPORT_FORMATS} (found {list(formats)})"
        )
    table = pa.table(flat_columns(store.rows(sweep=sweep, status=status)))
    stem = Path(stem)
    stem.parent.mkdir(parents=True, exist_ok=True)
    written = []
    for fmt in formats:
        out = stem.with_name(f"{stem.name}.{fmt}")
        if fmt == "parquet":
            pq.write_table(table, out)
        else:
            pa_csv.write_csv(table, out)
        written.append(out)
    return written


def flat_columns(rows: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """Export table columns (name -> ``pyarrow.Array``) from
    :meth:`~scenarios.store.ResultStore.rows`."""
    import pyarrow as pa

    flat = []
    for row in rows:
        record = {k: row[k] for k in META_COLUMNS}
        if row.get("sweep") is not None:
            record.update(sweep=row["sweep"], idx=row["idx"])
        record.update(_flatten(row["config"], "config."))
        record.update({f"result.{k}": v for k, v in _in_field_order(row).items()})
        flat.append(record)
    names: dict[str, None] = dict.fromkeys(META_COLUMNS)
    for record in flat:
        names.update(dict.fromkeys(record))
    return {name: _column([r.get(name) for r in flat], pa) for name in names}


def _flatten(data: Mapping[str, Any], prefix: str) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in data.items():
        if isinstance(value, Mapping):
            out.update(_flatten(value, f"{prefix}{key}."))
        else:
            out[prefix + key] = value
    return out


def _column(values: list[Any], pa: Any) -> Any:
    kinds = {_kind(v) for v in values if v is not None}
    if kinds == {"int", "float"}:
        kinds = {"float"}
    if len(kinds) > 1 or kinds == {"json"}:
        values = [None if v is None else json.dumps(v) for v in values]
        return pa.array(values, type=pa.string())
    types = {"bool": pa.bool_(), "int": pa.int64(), "float": pa.float64(), "str": pa.string()}
    return pa.array(values, type=types[kinds.pop()] if kinds else pa.null())


def _kind(value: Any) -> str:
    if isinstance(value, bool):
        return "bool"
    if isinstance(value, int):
        return "int"
    if isinstance(value, float):
        return "float"
    if isinstance(value, str):
        return "str"
    return "json"


def _in_field_order(row: Mapping[str, Any]) -> dict[str, Any]:
    """A row's result, the fields of its kind's row type first (:mod:`scenarios.rows`)."""
    result = row["result"]
    row_type = ROW_TYPES.get(str(row.get("kind")))
    if row_type is None:
        return dict(result)
    first = {k: result[k] for k in row_type.field_names() if k in result}
    return {**first, **{k: v for k, v in result.items() if k not in first}}
