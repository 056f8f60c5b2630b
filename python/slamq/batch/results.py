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

import json
import math
import os
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any, Union

from slamq.batch.records import ATE_COLUMNS, QUALITY_COLUMNS, RUN_COLUMNS
from slamq.errors import MapError, ParamError

__all__ = ["ResultsFile", "read_results", "read_records", "results_format", "KEY"]

KEY = ("algorithm", "sequence", "run", "map")
_JSONL = (".jsonl", ".ndjson")
_PARQUET = (".parquet", ".pq")

_INT_COLUMNS = {
    "unknown_value", "height", "width", "total", "known", "unknown", "occupied", "free",
    "corners", "enclosed_areas", "enclosed_unknown_value", "param_min_dot_area",
    "param_sweep_step", "param_min_area", "ate_n",
}
_STR_COLUMNS = {
    "map", "algorithm", "sequence", "run", "trajectory", "groundtruth", "hash", "config",
    "error",
    "source", "ate_error",
}

PathLike = Union[str, "os.PathLike[str]"]


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


def _clean(value: Any) -> Any:
    """JSON-ready: NaN -> None, numpy scalars -> Python, paths -> str."""
    if value is None or isinstance(value, (str, bool, int)):
        return value
    if isinstance(value, float):
        return None if math.isnan(value) or math.isinf(value) else value
    if isinstance(value, (list, tuple)):
        return [_clean(v) for v in value]
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    item = getattr(value, "item", None)
    if callable(item):
        return _clean(item())
    return str(value)


def _read_jsonl(path: Path, *, truncate_partial: bool = False) -> list[dict[str, Any]]:
    """Complete lines of a JSON Lines file; a partial or corrupt last line is dropped
    (and cut off the file when ``truncate_partial``)."""
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        return []
    except OSError as exc:
        raise MapError(f"{path}: cannot read results: {exc}") from exc
    end = data.rfind(b"\n") + 1
    if truncate_partial and end < len(data):
        with open(path, "r+b") as fh:
            fh.truncate(end)
            fh.flush()
            os.fsync(fh.fileno())
    records = []
    lines = data[:end].split(b"\n")
    for i, line in enumerate(lines):
        if not line.strip():
            continue
        try:
            rec = json.loads(line)
        except ValueError as exc:
            if i >= len(lines) - 2:  # a torn last line (kill -9 mid-write)
                continue
            raise MapError(f"{path}: line {i + 1}: not a JSON record: {exc}") from exc
        if not isinstance(rec, dict):
            raise MapError(f"{path}: line {i + 1}: not a JSON object")
        records.append(rec)
    return records


def _read_parquet(path: Path) -> list[dict[str, Any]]:
    if not path.exists():
        return []
    import pyarrow.parquet as pq

    try:
        table = pq.read_table(path)
    except Exception as exc:  # noqa: BLE001 - pyarrow raises several types
        raise MapError(f"{path}: not a readable Parquet file: {exc}") from exc
    return table.to_pylist()


def read_records(path: PathLike) -> list[dict[str, Any]]:
    """Every current record of a results file (last record per key wins), in file order.

    For Parquet, rows of an unfinished batch's journal are included.
    """
    path = Path(path)
    fmt = results_format(path)
    if fmt == "jsonl":
        if not path.exists():
            raise MapError(f"{path}: no such results file")
        records = _read_jsonl(path)
    else:
        jpath = journal_path(path)
        if not path.exists() and not jpath.exists():
            raise MapError(f"{path}: no such results file")
        records = _read_parquet(path) + _read_jsonl(jpath)
    return _dedup(records)


def _dedup(records: list[dict[str, Any]]) -> list[dict[str, Any]]:
    last: dict[tuple[str, str, str, str], int] = {}
    for i, rec in enumerate(records):
        last[_key(rec)] = i
    if len(last) == len(records):
        return records
    return [rec for i, rec in enumerate(records) if last[_key(rec)] == i]


def _ordered_columns(records: list[dict[str, Any]]) -> list[str]:
    cols: dict[str, None] = {}
    for name in RUN_COLUMNS + QUALITY_COLUMNS + ATE_COLUMNS:
        cols[name] = None
    for rec in records:
        for name in rec:
            cols.setdefault(name, None)
    present = {name for rec in records for name in rec}
    return [c for c in cols if c in present or c in RUN_COLUMNS]


def _arrow_table(records: list[dict[str, Any]]) -> Any:
    import pyarrow as pa

    cols = _ordered_columns(records)
    arrays = []
    for name in cols:
        values = [_clean(rec.get(name)) for rec in records]
        if name in _STR_COLUMNS:
            typ: Any = pa.string()
            values = [None if v is None else str(v) for v in values]
        elif name in _INT_COLUMNS:
            typ = pa.int64()
            values = [None if v is None else int(v) for v in values]
        elif name == "curve":
            typ = pa.list_(pa.int32())
        elif name.startswith(("param_", "ate_")) or name in QUALITY_COLUMNS or name == "seconds":
            typ = pa.float64()
            values = [None if v is None else float(v) for v in values]
        else:
            typ = None
        arrays.append(pa.array(values, type=typ))
    return pa.Table.from_arrays(arrays, names=cols)


def read_results(path: PathLike) -> Any:
    """Read a results file (``.jsonl`` or ``.parquet``) into a pandas DataFrame.

    One row per run (the last record of each ``(algorithm, sequence, run, map)``), in the
    order the batch produced them. A Parquet file's unfinished-batch journal is included,
    so the results of a killed batch can be read before it is resumed. Integer columns of
    failed rows are missing values; ``NaN`` ratios read back as ``NaN``.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "r.jsonl"
    >>> _ = p.write_text('{"map": "a.pgm", "algorithm": "x", "sequence": "s", "run": "0", '
    ...                  '"corners": 3, "error": null}\\n')
    >>> read_results(p)[["map", "corners"]].values.tolist()
    [['a.pgm', 3]]
    """
    table = _arrow_table(read_records(path))
    return table.to_pandas()


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


def _write_jsonl_atomic(path: Path, records: list[dict[str, Any]]) -> None:
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "w", encoding="utf-8") as fh:
        for rec in records:
            fh.write(_dumps(rec))
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)
    _fsync_dir(path.parent)


def _write_parquet_atomic(path: Path, records: list[dict[str, Any]], row_group: int) -> None:
    import pyarrow.parquet as pq

    tmp = path.with_name(path.name + ".tmp")
    table = _arrow_table(records)
    pq.write_table(table, tmp, row_group_size=max(1, row_group))
    with open(tmp, "rb") as fh:
        os.fsync(fh.fileno())
    os.replace(tmp, path)
    _fsync_dir(path.parent)


def _dumps(rec: dict[str, Any]) -> str:
    return json.dumps({k: _clean(v) for k, v in rec.items()}, allow_nan=False) + "\n"


class ResultsFile:
    """A results file being written by a batch (see the module docstring).

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
        if self.path.parent and not self.path.parent.exists():
            self.path.parent.mkdir(parents=True, exist_ok=True)
        self._append_to = self.path if self.format == "jsonl" else journal_path(self.path)
        # records already there (a resumed batch); a torn last line is cut off
        if self.format == "jsonl":
            stored = _read_jsonl(self.path, truncate_partial=True)
        else:
            stored = _read_parquet(self.path) + _read_jsonl(
                self._append_to, truncate_partial=True
            )
        self._stored_count = len(stored)
        self.existing: list[dict[str, Any]] = _dedup(stored)
        self._superseded = len(self.existing) != self._stored_count
        self._keys = {_key(r) for r in self.existing}
        self._appended = 0
        self._fh: Any | None = None

    def done(self) -> Iterator[tuple[tuple[str, str, str, str], dict[str, Any]]]:
        """``(key, record)`` of every stored record."""
        for rec in self.existing:
            yield _key(rec), rec

    def append(self, records: Iterable[dict[str, Any]]) -> None:
        """Append one finished chunk and make it durable (flush + fsync)."""
        lines = []
        for rec in records:
            k = _key(rec)
            if k in self._keys:
                self._superseded = True
            self._keys.add(k)
            lines.append(_dumps(rec))
        if not lines:
            return
        if self._fh is None:
            self._fh = open(self._append_to, "a", encoding="utf-8")
        self._fh.write("".join(lines))
        self._fh.flush()
        os.fsync(self._fh.fileno())
        self._appended += len(lines)

    def close(self) -> None:
        """Finish: rewrite without superseded rows (JSONL) / compact into Parquet."""
        if self._fh is not None:
            self._fh.close()
            self._fh = None
        if self.format == "jsonl":
            if self._superseded:
                _write_jsonl_atomic(self.path, _dedup(_read_jsonl(self.path)))
            elif not self.path.exists():
                self.path.touch()
            return
        jpath = self._append_to
        if not jpath.exists() and self.path.exists() and not self._superseded:
            return
        records = _dedup(_read_parquet(self.path) + _read_jsonl(jpath))
        _write_parquet_atomic(self.path, records, self.row_group)
        try:
            jpath.unlink()
        except FileNotFoundError:
            pass

    def __enter__(self) -> ResultsFile:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()
