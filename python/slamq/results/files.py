"""Results files: JSON Lines and Parquet, appended chunk by chunk, safe against kill -9.

* ``.jsonl`` (also ``.ndjson``): one JSON object per line, appended and ``fsync``-ed per
  chunk. A process killed while writing leaves at most a partial last line, which the next
  run cuts off before appending (and :func:`read_results` ignores).
* ``.parquet`` (also ``.pq``): a half-written Parquet file has no footer and cannot be read
  at all, so finished chunks go to a journal beside it, ``<out>.journal.jsonl``
  (the JSON Lines rules above), and the Parquet file is rewritten when the batch ends:
  written to ``<out>.tmp``, then renamed over ``<out>`` (atomic), then the journal is
  deleted. Killed at any point, the next run (or :func:`read_results`) sees the old
  Parquet file plus the journal.

Records are identified by ``(algorithm, sequence, run, map)``; when a key appears more
than once (a failed map retried, or a map re-evaluated with other parameters), the last
record wins. Both files are rewritten without the superseded rows at the end of a batch.
"""

from __future__ import annotations

import csv
import hashlib
import itertools
import json
import math
import os
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path
from typing import IO, Any

from slamq.errors import MapError, ParamError, SlamqError
from slamq.models import MapQuality
from slamq.results.columns import (
    ATE_COLUMNS,
    GT_COLUMNS,
    KEY,
    QUALITY_COLUMNS,
    RUN_COLUMNS,
    json_value,
)
from slamq.sources.files import PathLike, one_line

__all__ = [
    "ResultsFile",
    "digest64",
    "key_digest",
    "read_records",
    "read_results",
    "results_format",
    "write_csv",
    "write_json",
]

#: Besides the key, what resuming reads back from a results file.
_RESUME_COLUMNS = ("hash", "config", "trajectory", "groundtruth", "gt_map", "error")
_JSONL = (".jsonl", ".ndjson")
_PARQUET = (".parquet", ".pq")

_INT_COLUMNS = {
    "unknown_value", "height", "width", "total", "known", "unknown", "occupied", "free",
    "corners", "corners_canonical", "enclosed_areas", "enclosed_unknown_value",
    "param_min_dot_area",
    "param_sweep_step", "param_min_area", "ate_n", "gt_truncated", "gt_outside",
}
#: Float columns that are NaN when a map has no known cell (null in JSON).
_FLOAT_COLUMNS = {"occupied_fraction", "proportion", "threshold", "seconds",
                  "param_log_threshold", "param_harris_k", "param_harris_quality",
                  "param_canonical_resolution", "wall_angle", "known_box_m2"} | {
    f"ate_{s}" for s in ("rmse", "mean", "median", "std", "min", "max")} | {
    c for c in GT_COLUMNS if c not in ("gt_map", "gt_error", "gt_truncated", "gt_outside")}
_STR_COLUMNS = {
    "map", "algorithm", "sequence", "run", "trajectory", "groundtruth", "hash", "config",
    "error",
    "source", "ate_error", "gt_map", "gt_error", "saver", "flags",
}



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


def _key(rec: dict[str, Any]) -> tuple[str, str, str, str]:
    return tuple(str(rec.get(k)) for k in KEY)  # type: ignore[return-value]


def digest64(text: str) -> int:
    """A 64-bit digest of ``text`` (BLAKE2b, signed so that it fits an ``int64`` array).

    What a batch keeps per row instead of the row's key strings (resume, deduplication):
    8 bytes in a numpy array.

    Examples
    --------
    >>> digest64("a") == digest64("a") != digest64("b"), -2**63 <= digest64("a") < 2**63
    (True, True)
    """
    raw = hashlib.blake2b(text.encode("utf-8", "surrogatepass"), digest_size=8).digest()
    return int.from_bytes(raw, "little", signed=True)


def key_digest(key: Sequence[str]) -> int:
    """:func:`digest64` of a record key ``(algorithm, sequence, run, map)``.

    Examples
    --------
    >>> key_digest(("a", "s", "0", "m.pgm")) == key_digest(["a", "s", "0", "m.pgm"])
    True
    """
    return digest64("\0".join(key))


def _key_digests128(records: Iterable[dict[str, Any]]) -> Any:
    """The 128-bit digests of the records' keys, in order, as an ``(n, 2)`` int64 array
    (what deciding which rows to drop relies on: a collision would lose a row)."""
    import numpy as np

    raw = b"".join(
        hashlib.blake2b("\0".join(_key(r)).encode("utf-8", "surrogatepass"),
                        digest_size=16).digest()
        for r in records)
    return np.frombuffer(raw, dtype="<i8").reshape(-1, 2).astype(np.int64)


def _last_of_each(digests: Any) -> Any:
    """A boolean mask: True at the last row of each distinct digest (``(n,)`` or ``(n, k)``
    int64 array), False at the rows a later row supersedes."""
    import numpy as np

    n = len(digests)
    keep = np.zeros(n, dtype=bool)
    if n == 0:
        return keep
    d = digests.reshape(n, -1)
    order = np.lexsort(d.T[::-1])  # stable: equal digests stay in file order
    s = d[order]
    last = np.ones(n, dtype=bool)
    last[:-1] = (s[1:] != s[:-1]).any(axis=1)
    keep[order[last]] = True
    return keep


def _cut_torn_tail(path: Path) -> None:
    """Cut a partial last line (a write interrupted by kill -9) off a JSON Lines file."""
    try:
        fh = open(path, "r+b")
    except FileNotFoundError:
        return
    with fh:
        size = fh.seek(0, os.SEEK_END)
        pos = size
        while pos > 0:
            step = min(65536, pos)
            fh.seek(pos - step)
            block = fh.read(step)
            nl = block.rfind(b"\n")
            if nl >= 0:
                pos = pos - step + nl + 1
                break
            pos -= step
        if pos < size:
            fh.truncate(pos)
            fh.flush()
            os.fsync(fh.fileno())


def _iter_jsonl(path: Path) -> Iterator[dict[str, Any]]:
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


def _jsonl_tables(path: Path, batch: int = 1024) -> Iterator[Any]:
    """A JSON Lines file as Arrow tables of at most ``batch`` rows (bounded memory)."""
    rows: list[dict[str, Any]] = []
    for rec in _iter_jsonl(path):
        rows.append(rec)
        if len(rows) >= batch:
            yield _typed_table(rows, path)
            rows = []
    if rows:
        yield _typed_table(rows, path)


def _typed_table(rows: list[dict[str, Any]], path: Path) -> Any:
    """:func:`_arrow_table`, or a MapError naming the file and the column whose values
    are not of its type (a tampered or foreign file)."""
    try:
        return _arrow_table(rows)
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


def _parquet_rows(path: Path, columns: list[str], batch: int = 1024) -> Iterator[dict[str, Any]]:
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


def _concat(tables: list[Any]) -> Any:
    import pyarrow as pa

    tables = [t for t in tables if t.num_rows or len(tables) == 1]
    if not tables:
        return _arrow_table([])
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
        return _dedup_table(_concat(list(_jsonl_tables(path))))
    jpath = journal_path(path)
    if not path.exists() and not jpath.exists():
        raise MapError(f"{path}: no such results file")
    tables = [_parquet_table(path)] if path.exists() else []
    tables += list(_jsonl_tables(jpath))
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
    if _readable_format(path) == "plain":
        return _read_plain(path)
    return _results_table(path).to_pylist()


def _ordered_columns(records: list[dict[str, Any]]) -> list[str]:
    cols: dict[str, None] = {}
    for name in RUN_COLUMNS + QUALITY_COLUMNS + ATE_COLUMNS + GT_COLUMNS:
        cols[name] = None
    for rec in records:
        for name in rec:
            cols.setdefault(name, None)
    present = {name for rec in records for name in rec}
    return [c for c in cols if c in present or c in RUN_COLUMNS]


class _ColumnError(ValueError):
    """A column whose values are not of its type."""


def _arrow_table(records: list[dict[str, Any]]) -> Any:
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

    if name in _STR_COLUMNS:
        typ: Any = pa.string()
        values = [None if v is None else str(v) for v in values]
    elif name in _INT_COLUMNS:
        typ = pa.int64()
        values = [None if v is None else int(v) for v in values]
    elif name == "curve":
        typ = pa.list_(pa.int32())
    elif (name.startswith(("param_", "ate_", "gt_")) or name in QUALITY_COLUMNS
          or name == "seconds"):
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
            if v is None and k in _FLOAT_COLUMNS:
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
        elif k == "curve":
            out[k] = [int(c) for c in v.split(";") if c]
        elif k in _INT_COLUMNS:
            out[k] = int(v)
        elif k in _FLOAT_COLUMNS or k.startswith("param_"):
            out[k] = float(v)
            if k.startswith("param_") and out[k].is_integer() and k in _INT_COLUMNS:
                out[k] = int(out[k])
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
    return list(QUALITY_COLUMNS)


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


#: The float fields that are NaN when a map has no known cell (null in JSON).
_RATIOS = ("occupied_fraction", "proportion", "threshold")


def _fsync_dir(path: Path) -> None:
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def _rewrite_jsonl_dedup(path: Path) -> None:
    """Rewrite a JSON Lines file without superseded rows (two streaming passes; 16 bytes
    of memory per row, a 128-bit digest of its key)."""
    keep = _last_of_each(_key_digests128(_iter_jsonl(path)))
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "w", encoding="utf-8") as fh:
        for i, rec in enumerate(itertools.islice(_iter_jsonl(path), len(keep))):
            if keep[i]:
                fh.write(_dumps(rec))
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)
    _fsync_dir(path.parent)


#: A journal of at most this many rows is parsed once when compacted (its Arrow tables,
#: about 1 KB a row, are kept between the two passes); a longer one is parsed twice.
_KEEP_JOURNAL_ROWS = 4096


def _compact_parquet(path: Path, journal: Path, row_group: int) -> None:
    """Parquet file + journal -> a new Parquet file (atomic rename), then drop the journal.

    Streamed: a first pass takes the 128-bit key digest of every row (16 bytes each) and
    the columns of every part, from the same Arrow tables (the journal parsed once for
    both); the second writes the rows no later row supersedes, a row group at a time;
    memory does not hold the table, except the first pass's tables of a journal of at most
    :data:`_KEEP_JOURNAL_ROWS` rows, which the second pass then uses instead of parsing the
    journal again. (Keeping every journal's tables in a temporary Arrow IPC file instead
    raised a 4,500-row batch's peak memory by ~5 MiB more than a 1,500-row one's.)
    """
    import numpy as np
    import pyarrow as pa
    import pyarrow.parquet as pq

    row_group = max(1, row_group)
    schemas = []
    if path.exists():
        try:
            schemas.append(pq.read_schema(path))
        except Exception as exc:  # noqa: BLE001 - pyarrow raises several types
            raise MapError(f"{path}: not a readable Parquet file: {exc}") from exc
    digests = [_key_digests128(_parquet_rows(path, list(KEY)))] if path.exists() else []
    kept: list[Any] | None = []  # the journal's tables while they are few
    for table in _jsonl_tables(journal):
        schemas.append(table.schema)
        digests.append(_table_key_digests128(table))
        if kept is not None:
            kept.append(table)
            if sum(t.num_rows for t in kept) > _KEEP_JOURNAL_ROWS:
                kept = None
    schema = _unify(schemas) if schemas else _arrow_table([]).schema
    keep = _last_of_each(np.concatenate(digests) if digests else np.zeros((0, 2), np.int64))

    def parts() -> Iterator[Any]:
        if path.exists():
            for b in pq.ParquetFile(path).iter_batches(batch_size=row_group):
                yield pa.Table.from_batches([b])
        yield from (_jsonl_tables(journal) if kept is None else kept)

    tmp = path.with_name(path.name + ".tmp")
    start = 0
    pending: list[Any] = []
    with pq.ParquetWriter(tmp, schema) as writer:
        for table in parts():
            n = table.num_rows
            mask = keep[start : start + n]
            start += n
            if not mask.all():
                table = table.filter(pa.array(mask))
            pending.append(_conform(table, schema))
            if sum(t.num_rows for t in pending) >= row_group:
                writer.write_table(pa.concat_tables(pending), row_group_size=row_group)
                pending = []
        if pending or start == 0:
            writer.write_table(pa.concat_tables(pending) if pending else schema.empty_table(),
                               row_group_size=row_group)
    with open(tmp, "rb") as fh:
        os.fsync(fh.fileno())
    os.replace(tmp, path)
    _fsync_dir(path.parent)
    try:
        journal.unlink()
    except FileNotFoundError:
        pass


def _table_key_digests128(table: Any) -> Any:
    """:func:`_key_digests128` of the rows of an Arrow table (a key column it lacks is
    None in every row, as in a record without that key)."""
    cols = [table.column(k).to_pylist() if k in table.column_names
            else [None] * table.num_rows for k in KEY]
    return _key_digests128(dict(zip(KEY, row)) for row in zip(*cols))


def _unify(schemas: list[Any]) -> Any:
    """One schema for the parts of a results file (a column all null in one part takes
    the other parts' type)."""
    import pyarrow as pa

    try:
        return pa.unify_schemas(schemas, promote_options="permissive")
    except TypeError:  # pyarrow < 14
        return pa.unify_schemas(schemas)


def _conform(table: Any, schema: Any) -> Any:
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


#: Value types :func:`_dumps` writes as they are (``json_value`` leaves them unchanged, but
#: for a float that is NaN or infinite).
_PLAIN = frozenset({str, int, float, bool, type(None)})


def _dumps(rec: dict[str, Any]) -> str:
    """One JSON line of a record: values through :func:`json_value` (NaN -> null, numpy
    scalars -> numbers, paths -> strings). A record of plain values (what a batch makes)
    is dumped as it is: the same line, without a call per value."""
    if all(type(v) in _PLAIN for v in rec.values()):
        bad = [k for k, v in rec.items() if type(v) is float and not math.isfinite(v)]
        if bad:  # NaN and infinities: null, as json_value says
            rec = {**rec, **dict.fromkeys(bad)}
        return json.dumps(rec, allow_nan=False) + "\n"
    return json.dumps({k: json_value(v) for k, v in rec.items()}, allow_nan=False) + "\n"


def lock_path(path: PathLike) -> Path:
    """The lock file beside a results file (``<out>.lock``)."""
    p = Path(path)
    return p.with_name(p.name + ".lock")


def _lock(path: Path) -> Any:
    """Take the advisory lock of a results file for this process, or raise a SlamqError
    naming the process that holds it (two batches on one file lost 40-50% of the rows)."""
    import fcntl

    fh = open(lock_path(path), "a+", encoding="utf-8")
    try:
        fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        fh.seek(0)
        holder = fh.read().strip()[:40] or "unknown"
        fh.close()
        raise SlamqError(
            f"{path}: another slamq process (pid {holder}) is writing these results; wait "
            "for it to finish (rerunning the same command then resumes), or write to another "
            "results file") from None
    fh.seek(0)
    fh.truncate()
    fh.write(f"{os.getpid()}\n")
    fh.flush()
    return fh


def _write_error(path: Path, exc: OSError) -> SlamqError:
    reason = exc.strerror or one_line(exc)
    return SlamqError(f"{path}: cannot write results: {reason}; the rows written before "
                      "stay, and rerunning the batch resumes after them")


class ResultsFile:
    """A results file being written by a batch (see the module docstring).

    Opening it takes an advisory lock (``fcntl.flock`` on ``<out>.lock`` beside it): a
    second writer gets a :class:`~slamq.errors.SlamqError` naming the first one's pid
    (``slamq batch`` exits 2) instead of both losing rows. Dask workers never write it;
    the process that runs the batch does. Opening it also cuts a torn last line (left by
    kill -9) off the append file and reads what resuming needs (keys, content hashes,
    settings, errors), not whole records.

    Parameters
    ----------
    path : path
        ``*.jsonl`` or ``*.parquet``.
    row_group : int
        Rows per Parquet row group when the file is rewritten.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "r.parquet"
    >>> with ResultsFile(p) as rf:
    ...     rf.append([{"map": "m.pgm", "algorithm": "a", "sequence": "s", "run": "0"}])
    >>> len(read_results(p))
    1
    """

    def __init__(self, path: PathLike, *, row_group: int = 1024) -> None:
        self.path = Path(path)
        self.format = results_format(self.path)
        self.row_group = row_group
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._lock = _lock(self.path)  # one writer at a time, or rows are lost
        self._append_to = self.path if self.format == "jsonl" else journal_path(self.path)
        _cut_torn_tail(self._append_to)
        import numpy as np

        # What resuming needs, without a Python object per row: the 64-bit key digests of
        # the stored rows (8 bytes each; a collision only costs a re-evaluation or a
        # needless rewrite, never a row: the rewrite compares 128-bit digests).
        digests = np.fromiter((key_digest(_key(r)) for r in self._stored_records(KEY)),
                              dtype=np.int64)
        self._count = len(digests)  # rows stored when the file was opened
        self._last = _last_of_each(digests)
        #: sorted distinct key digests of the stored rows and of the rows merged since
        self._known = np.unique(digests)
        self._superseded = len(self._known) < self._count
        self._new: set[int] = set()  # digests appended since the last merge into _known
        self._fh: Any | None = None

    def _stored_records(self, columns: Sequence[str]) -> Iterator[dict[str, Any]]:
        """The stored rows (``columns`` of each), streamed in file order: the Parquet file
        a row group at a time, then the append file."""
        if self.format == "parquet" and self.path.exists():
            yield from _parquet_rows(self.path, list(columns))
        for rec in _iter_jsonl(self._append_to):
            yield {k: rec.get(k) for k in columns}

    def done(self) -> Iterator[tuple[tuple[str, str, str, str], dict[str, Any]]]:
        """``(key, record)`` of every stored run (its last row), read from the file again
        as it is iterated; the record holds the key columns and ``hash, config,
        trajectory, groundtruth, gt_map, error``."""
        rows = itertools.islice(self._stored_records(KEY + _RESUME_COLUMNS), self._count)
        for rec, last in zip(rows, self._last):
            if last:
                yield _key(rec), rec

    def __len__(self) -> int:
        return int(self._last.sum())

    def append(self, records: Iterable[dict[str, Any]]) -> None:
        """Append one finished chunk and make it durable (flush + fsync)."""
        lines = []
        for rec in records:
            if not self._superseded:  # once it is, the file is deduplicated at the end
                self._note(key_digest(_key(rec)))
            lines.append(_dumps(rec))
        if not lines:
            return
        try:
            if self._fh is None:
                self._fh = open(self._append_to, "a", encoding="utf-8")
            self._fh.write("".join(lines))
            self._fh.flush()
            os.fsync(self._fh.fileno())
        except OSError as exc:  # a full disk, a quota, a file size limit
            raise _write_error(self._append_to, exc) from None

    def _note(self, digest: int) -> None:
        """Note an appended key: superseded if it was stored or appended before."""
        import numpy as np

        i = int(np.searchsorted(self._known, digest))
        if digest in self._new or (i < len(self._known) and int(self._known[i]) == digest):
            self._superseded = True
            return
        self._new.add(digest)
        if len(self._new) >= 1024:  # merge: 8 bytes per key afterwards
            self._known = np.union1d(self._known, np.fromiter(self._new, dtype=np.int64))
            self._new.clear()

    def close(self) -> None:
        """Finish: rewrite without superseded rows (JSONL) / compact into Parquet."""
        try:
            if self._fh is not None:
                fh, self._fh = self._fh, None
                fh.close()
            if self.format == "jsonl":
                if self._superseded:
                    _rewrite_jsonl_dedup(self.path)
                elif not self.path.exists():
                    self.path.touch()
                return
            if self._append_to.exists() or not self.path.exists() or self._superseded:
                _compact_parquet(self.path, self._append_to, self.row_group)
        except OSError as exc:
            raise _write_error(self.path, exc) from None
        finally:
            if self._lock is not None:
                self._lock.close()  # releases the flock
                self._lock = None

    def __enter__(self) -> ResultsFile:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()
