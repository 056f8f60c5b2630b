"""The four results file formats: how a record is written and read back.

* ``.json`` and ``.csv`` (``slamq eval --json/--csv``): one record per map, written whole by
  :func:`write_json` / :func:`write_csv`.
* ``.jsonl`` (also ``.ndjson``): one JSON object per line (:func:`dumps_record`); a torn
  last line (a write cut by kill -9) is skipped when read.
* ``.parquet`` (also ``.pq``): typed Arrow columns; an unfinished batch's rows wait in a
  journal beside it, ``<out>.journal.jsonl`` (:func:`journal_path`), which reading includes.

:func:`read_results` / :func:`read_records` read any of them (the last record of each
``(algorithm, sequence, run, map)`` wins). Writing a batch's file chunk by chunk, resuming,
locking and compaction are :mod:`slamq.results.store`'s.
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any

from slamq.columns import COLUMNS, group_names, record_columns
from slamq.errors import MapError, ParamError, SlamqError
from slamq.results.columns import KEY, json_value

if TYPE_CHECKING:  # annotations only: reading a results file needs neither (nor numpy)
    from slamq.models import MapQuality
    from slamq.sources.files import PathLike

__all__ = [
    "dumps_record",
    "journal_path",
    "read_records",
    "read_results",
    "results_format",
    "write_csv",
    "write_json",
]

_JSONL = (".jsonl", ".ndjson")
_PARQUET = (".parquet", ".pq")

#: Prefixes of the column families: a column of such a name that the table lacks (written
#: by another version of slamq) is read as a number.
_NUMBER_PREFIXES = ("param_", "ate_", "gt_")


def _dtype(name: str) -> str | None:
    """The type of column ``name`` (:data:`slamq.columns.COLUMNS`), None when unknown."""
    col = COLUMNS.get(name)
    if col is not None:
        return col.dtype
    return "float" if name.startswith(_NUMBER_PREFIXES) else None


def results_format(path: PathLike) -> str:
    """``"jsonl"`` or ``"parquet"`` from the file name.

    Examples
    --------
    >>> results_format("out/results.parquet"), results_format("r.jsonl")
    ('parquet', 'jsonl')
    """
    suffix = Path(path).suffix.lower()
    if suffix in _JSONL:
        return "jsonl"
    if suffix in _PARQUET:
        return "parquet"
    raise ParamError(
        f"{path}: unknown results format {suffix!r}; use .parquet or .jsonl"
    )


def journal_path(path: PathLike) -> Path:
    """Where a Parquet results file keeps the chunks of an unfinished batch."""
    p = Path(path)
    return p.with_name(p.name + ".journal.jsonl")


def iter_jsonl(path: Path) -> Iterator[dict[str, Any]]:
    """The records of a JSON Lines file, streamed; a torn last line is skipped."""
    try:
        fh = open(path, "rb")
    except FileNotFoundError:
        return
    except OSError as exc:
        raise MapError(f"{path}: cannot read results: {exc}") from exc
    with fh:
        for i, line in enumerate(fh, start=1):
            if not line.strip():
                continue
            try:
                rec = json.loads(line)
            except ValueError as exc:
                if not line.endswith(b"\n"):
                    continue  # the unterminated last line of a write cut by kill -9
                raise MapError(f"{path}: line {i}: not a JSON record: {exc}") from exc
            if not isinstance(rec, dict):
                raise MapError(f"{path}: line {i}: not a JSON object")
            yield rec


def jsonl_tables(path: Path, batch: int = 1024) -> Iterator[Any]:
    """A JSON Lines file as Arrow tables of at most ``batch`` rows (bounded memory)."""
    rows: list[dict[str, Any]] = []
    for rec in iter_jsonl(path):
        rows.append(rec)
        if len(rows) >= batch:
            yield _typed_table(rows, path)
            rows = []
    if rows:
        yield _typed_table(rows, path)


def _typed_table(rows: list[dict[str, Any]], path: Path) -> Any:
    """:func:`arrow_table`, or a MapError naming the file and the column whose values
    are not of its type (a tampered or foreign file)."""
    try:
        return arrow_table(rows)
    except _ColumnError as exc:
        raise MapError(f"{path}: not a slamq results file: {exc}") from None


def _parquet_table(path: Path, columns: list[str] | None = None) -> Any:
    import pyarrow.parquet as pq

    try:
        if columns is not None:
            have = set(pq.read_schema(path).names)
            columns = [c for c in columns if c in have]
        return pq.read_table(path, columns=columns)
    except Exception as exc:  # noqa: BLE001 - pyarrow raises several types
        raise MapError(f"{path}: not a readable Parquet file: {exc}") from exc


def parquet_rows(path: Path, columns: list[str], batch: int = 1024) -> Iterator[dict[str, Any]]:
    """The rows of a Parquet file (those of ``columns`` it has), a batch at a time."""
    import pyarrow.parquet as pq

    try:
        pf = pq.ParquetFile(path)
        have = set(pf.schema_arrow.names)
        batches = pf.iter_batches(batch_size=batch, columns=[c for c in columns if c in have])
        for b in batches:
            yield from b.to_pylist()
    except Exception as exc:  # noqa: BLE001 - pyarrow raises several types
        if isinstance(exc, SlamqError):
            raise
        raise MapError(f"{path}: not a readable Parquet file: {exc}") from exc


def _jsonl_records(path: Path) -> list[dict[str, Any]]:
    """The current records of a JSON Lines results file, without Arrow: what
    ``_results_table(path).to_pylist()`` gives for the columns of
    :data:`slamq.columns.COLUMNS` (each record has every column, typed as the table says;
    the last record of each key wins, in file order), other columns as the file has them."""
    if not path.exists():
        raise MapError(f"{path}: no such results file")
    rows = list(iter_jsonl(path))
    cols = _ordered_columns(rows)
    typed = []
    for name in cols:
        convert = _PLAIN_TYPES.get(_dtype(name) or "")
        values = [json_value(r.get(name)) for r in rows]
        if convert is not None:
            try:
                values = [None if v is None else convert(v) for v in values]
            except (TypeError, ValueError, OverflowError) as exc:
                raise MapError(f"{path}: not a slamq results file: column {name!r}: "
                               f"{' '.join(str(exc).split())[:120]}") from None
        typed.append(values)
    records = [dict(zip(cols, values, strict=True)) for values in zip(*typed, strict=True)]
    if not records:
        return []
    last: dict[tuple[Any, ...], int] = {}
    for i, rec in enumerate(records):
        last[tuple(None if rec[k] is None else str(rec[k]) for k in KEY)] = i
    return [records[i] for i in sorted(last.values())]


def _ints(value: Any) -> list[int | None]:
    if not isinstance(value, list):
        raise TypeError(f"expected a list of integers, got {type(value).__name__}")
    return [None if v is None else int(v) for v in value]


#: How a record's value of each column type is converted (as :func:`_arrow_column` does).
_PLAIN_TYPES: dict[str, Any] = {"str": str, "int": int, "float": float, "ints": _ints}


def _concat(tables: list[Any]) -> Any:
    import pyarrow as pa

    tables = [t for t in tables if t.num_rows or len(tables) == 1]
    if not tables:
        return arrow_table([])
    if len(tables) == 1:
        return tables[0]
    try:
        return pa.concat_tables(tables, promote_options="permissive")
    except TypeError:  # pyarrow < 14
        return pa.concat_tables(tables, promote=True)


def _dedup_table(table: Any) -> Any:
    """Keep the last row of every ``(algorithm, sequence, run, map)``, in file order."""
    import pyarrow as pa

    if table.num_rows == 0 or not all(k in table.column_names for k in KEY):
        return table
    keys = table.select(list(KEY)).to_pandas()
    keep = ~keys.astype(str).duplicated(keep="last").to_numpy()
    if keep.all():
        return table
    return table.filter(pa.array(keep))


def _results_table(path: Path) -> Any:
    """A results file (plus a Parquet file's journal) as one deduplicated Arrow table."""
    fmt = results_format(path)
    if fmt == "jsonl":
        if not path.exists():
            raise MapError(f"{path}: no such results file")
        return _dedup_table(_concat(list(jsonl_tables(path))))
    jpath = journal_path(path)
    if not path.exists() and not jpath.exists():
        raise MapError(f"{path}: no such results file")
    tables = [_parquet_table(path)] if path.exists() else []
    tables += list(jsonl_tables(jpath))
    return _dedup_table(_concat(tables))


def read_records(path: PathLike) -> list[dict[str, Any]]:
    """Every current record of a results file (last record per key wins), in file order.

    Any results file slamq writes (``.jsonl``, ``.parquet``, ``.json``, ``.csv``); for
    Parquet, rows of an unfinished batch's journal are included.

    Examples
    --------
    >>> import json, tempfile, os
    >>> p = os.path.join(tempfile.mkdtemp(), "r.json")
    >>> _ = open(p, "w").write(json.dumps([{"corners": 3, "proportion": None}]))
    >>> read_records(p)
    [{'corners': 3, 'proportion': nan}]
    """
    path = Path(path)
    fmt = _readable_format(path)
    if fmt == "plain":
        return _read_plain(path)
    if fmt == "jsonl":
        return _jsonl_records(path)
    return _results_table(path).to_pylist()


def _ordered_columns(records: list[dict[str, Any]]) -> list[str]:
    cols: dict[str, None] = dict.fromkeys(record_columns(curve=True))
    for rec in records:
        for name in rec:
            cols.setdefault(name, None)
    present = {name for rec in records for name in rec}
    run = set(group_names("run"))
    return [c for c in cols if c in present or c in run]


class _ColumnError(ValueError):
    """A column whose values are not of its type."""


def arrow_table(records: list[dict[str, Any]]) -> Any:
    import pyarrow as pa

    cols = _ordered_columns(records)
    arrays = []
    for name in cols:
        try:
            arrays.append(_arrow_column(name, [json_value(r.get(name)) for r in records]))
        except (TypeError, ValueError, OverflowError, pa.ArrowException) as exc:
            raise _ColumnError(f"column {name!r}: {' '.join(str(exc).split())[:120]}"
                               ) from None
    return pa.Table.from_arrays(arrays, names=cols)


def _arrow_column(name: str, values: list[Any]) -> Any:
    """One typed Arrow column of a results table."""
    import pyarrow as pa

    dtype = _dtype(name)
    if dtype == "str":
        typ: Any = pa.string()
        values = [None if v is None else str(v) for v in values]
    elif dtype == "int":
        typ = pa.int64()
        values = [None if v is None else int(v) for v in values]
    elif dtype == "ints":
        typ = pa.list_(pa.int32())
    elif dtype == "float":
        typ = pa.float64()
        values = [None if v is None else float(v) for v in values]
    else:
        typ = None
    return pa.array(values, type=typ)


def read_results(path: PathLike) -> Any:
    """Read any results file slamq writes into a pandas DataFrame.

    ``.jsonl`` and ``.parquet`` (``slamq batch``): one row per run (the last record of
    each ``(algorithm, sequence, run, map)``), in the order the batch produced them; a
    Parquet file's unfinished-batch journal is included, so the results of a killed batch
    can be read before it is resumed. ``.json`` and ``.csv`` (``slamq eval --json/--csv``):
    one row per map. Integer columns of failed rows are missing values; ``NaN`` ratios
    read back as ``NaN``.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "r.jsonl"
    >>> _ = p.write_text('{"map": "a.pgm", "algorithm": "x", "sequence": "s", "run": "0", '
    ...                  '"corners": 3, "error": null}\\n')
    >>> read_results(p)[["map", "corners"]].values.tolist()
    [['a.pgm', 3]]
    """
    import pandas as pd

    path = Path(path)
    if _readable_format(path) == "plain":
        return pd.DataFrame(read_records(path))
    return _results_table(path).to_pandas()


def _readable_format(path: Path) -> str:
    """"plain" (``.json``/``.csv``) or the batch format; ParamError for anything else."""
    suffix = path.suffix.lower()
    if suffix in (".json", ".csv"):
        return "plain"
    if suffix in _JSONL + _PARQUET:
        return results_format(path)
    raise ParamError(f"{path}: unknown results format {suffix!r}; slamq reads .parquet, "
                     ".jsonl, .json and .csv")


def _read_plain(path: Path) -> list[dict[str, Any]]:
    """The records of a ``slamq eval --json`` / ``--csv`` file (ratios null -> NaN)."""


    try:
        if path.suffix.lower() == ".json":
            records = json.loads(path.read_text(encoding="utf-8"))
            if isinstance(records, dict):
                records = records.get("results", [])
            if not isinstance(records, list) or not all(isinstance(r, dict) for r in records):
                raise MapError(f"{path}: not a slamq results file (expected a JSON list of "
                               "records)")
        else:
            with path.open(newline="", encoding="utf-8") as fh:
                records = [_csv_record(r) for r in csv.DictReader(fh)]
    except FileNotFoundError:
        raise MapError(f"{path}: no such results file") from None
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise MapError(f"{path}: cannot read results: {' '.join(str(exc).split())}") from None
    for r in records:
        for k, v in r.items():
            if v is None and _dtype(k) == "float":
                r[k] = math.nan
        if "map" not in r and "source" in r:  # slamq eval's records name the map "source"
            r["map"] = r["source"]
    return records


def _csv_record(row: dict[str, str]) -> dict[str, Any]:
    """A CSV row with its numbers as numbers, blanks as None, the curve as a list."""
    out: dict[str, Any] = {}
    for k, v in row.items():
        if v is None or v == "":
            out[k] = None
        elif _dtype(k) == "ints":
            out[k] = [int(c) for c in v.split(";") if c]
        elif _dtype(k) == "int":
            out[k] = int(v)
        elif _dtype(k) == "float":
            out[k] = float(v)
        else:
            out[k] = v
    return out




def _records(results: Sequence[MapQuality]) -> list[dict[str, Any]]:
    return [q.to_dict() for q in results]


def write_json(path: PathLike | IO[str], results: Sequence[MapQuality]) -> Path | None:
    """Write the results as a JSON list of ``MapQuality.to_dict()`` (NaN as null).

    ``path`` may be an open text stream (e.g. ``sys.stdout``); then None is returned.

    Examples
    --------
    >>> import numpy as np, slamq, tempfile, os
    >>> q = slamq.evaluate(np.full((4, 4), 254, np.uint8))
    >>> p = write_json(os.path.join(tempfile.mkdtemp(), "r.json"), [q])
    >>> read_records(p)[0]["known"]
    16
    """
    records = [{k: json_value(v) for k, v in r.items()} for r in _records(results)]
    text = json.dumps(records, indent=2) + "\n"
    if hasattr(path, "write"):
        path.write(text)
        return None
    path = Path(path)
    path.write_text(text)
    return path


def _csv_header() -> list[str]:
    """The columns of ``MapQuality.to_dict()``, for a file with no result."""
    return list(group_names("map", "param"))


def write_csv(path: PathLike | IO[str], results: Sequence[MapQuality]) -> Path | None:
    """Write one CSV row per map (the curve, when present, as ``;``-joined counts).

    ``path`` may be an open text stream (e.g. ``sys.stdout``); then None is returned.
    """
    records = _records(results)
    fields = list(records[0].keys()) if records else _csv_header()

    def write(fh: IO[str]) -> None:
        writer = csv.DictWriter(fh, fieldnames=fields)
        writer.writeheader()
        for r in records:
            if r.get("curve") is not None:
                r["curve"] = ";".join(str(c) for c in r["curve"])
            writer.writerow(r)

    if hasattr(path, "write"):
        write(path)
        return None
    path = Path(path)
    with path.open("w", newline="") as fh:
        write(fh)
    return path


def unify_schemas(schemas: list[Any]) -> Any:
    """One schema for the parts of a results file (a column all null in one part takes
    the other parts' type)."""
    import pyarrow as pa

    try:
        return pa.unify_schemas(schemas, promote_options="permissive")
    except TypeError:  # pyarrow < 14
        return pa.unify_schemas(schemas)


def conform_table(table: Any, schema: Any) -> Any:
    """``table`` with the columns of ``schema``, in its order and types (nulls for the
    columns it lacks)."""
    import pyarrow as pa

    arrays = []
    for field in schema:
        if field.name in table.column_names:
            col = table.column(field.name)
            arrays.append(col if col.type == field.type else col.cast(field.type))
        else:
            arrays.append(pa.nulls(table.num_rows, field.type))
    return pa.Table.from_arrays(arrays, schema=schema)


#: Value types :func:`dumps_record` writes as they are (``json_value`` leaves them unchanged, but
#: for a float that is NaN or infinite).
_PLAIN = frozenset({str, int, float, bool, type(None)})


def dumps_record(rec: dict[str, Any]) -> str:
    """One JSON line of a record: values through :func:`json_value` (NaN -> null, numpy
    scalars -> numbers, paths -> strings). A record of plain values (what a batch makes)
    is dumped as it is: the same line, without a call per value."""
    if all(type(v) in _PLAIN for v in rec.values()):
        bad = [k for k, v in rec.items() if type(v) is float and not math.isfinite(v)]
        if bad:  # NaN and infinities: null, as json_value says
            rec = {**rec, **dict.fromkeys(bad)}
        return json.dumps(rec, allow_nan=False) + "\n"
    return json.dumps({k: json_value(v) for k, v in rec.items()}, allow_nan=False) + "\n"
