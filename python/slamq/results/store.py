"""The resumable results store of a batch: appended chunk by chunk, safe against kill -9.

* ``.jsonl``: each chunk appended and ``fsync``-ed. A process killed while writing leaves
  at most a partial last line, which the next run cuts off before appending (and
  :func:`~slamq.results.formats.read_results` ignores).
* ``.parquet``: a half-written Parquet file has no footer and cannot be read at all, so
  finished chunks go to a journal beside it, ``<out>.journal.jsonl`` (the JSON Lines rules
  above), and the Parquet file is rewritten when the batch ends: written to ``<out>.tmp``,
  then renamed over ``<out>`` (atomic), then the journal is deleted. Killed at any point,
  the next run (or ``read_results``) sees the old Parquet file plus the journal.

Records are identified by ``(algorithm, sequence, run, map)``; when a key appears more
than once (a failed map retried, or a map re-evaluated with other parameters), the last
record wins. Both files are rewritten without the superseded rows at the end of a batch
(compaction, streamed on 128-bit key digests). One writer at a time: ``<out>.lock``.
The formats themselves (typed columns, JSON lines, reading) are
:mod:`slamq.results.formats`'.
"""

from __future__ import annotations

import hashlib
import itertools
import os
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path
from typing import Any

from slamq.errors import MapError, SlamqError
from slamq.results.columns import KEY
from slamq.results.formats import (
    arrow_table,
    conform_table,
    dumps_record,
    iter_jsonl,
    journal_path,
    jsonl_tables,
    parquet_rows,
    results_format,
    unify_schemas,
)
from slamq.sources.files import PathLike, one_line

__all__ = [
    "ResultsFile",
    "digest64",
    "key_digest",
    "lock_path",
]

#: Besides the key, what resuming reads back from a results file.
_RESUME_COLUMNS = ("hash", "config", "trajectory", "groundtruth", "gt_map", "relations",
                   "error")


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
    keep = _last_of_each(_key_digests128(iter_jsonl(path)))
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "w", encoding="utf-8") as fh:
        for i, rec in enumerate(itertools.islice(iter_jsonl(path), len(keep))):
            if keep[i]:
                fh.write(dumps_record(rec))
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
    digests = [_key_digests128(parquet_rows(path, list(KEY)))] if path.exists() else []
    kept: list[Any] | None = []  # the journal's tables while they are few
    for table in jsonl_tables(journal):
        schemas.append(table.schema)
        digests.append(_table_key_digests128(table))
        if kept is not None:
            kept.append(table)
            if sum(t.num_rows for t in kept) > _KEEP_JOURNAL_ROWS:
                kept = None
    schema = unify_schemas(schemas) if schemas else arrow_table([]).schema
    keep = _last_of_each(np.concatenate(digests) if digests else np.zeros((0, 2), np.int64))

    def parts() -> Iterator[Any]:
        if path.exists():
            for b in pq.ParquetFile(path).iter_batches(batch_size=row_group):
                yield pa.Table.from_batches([b])
        yield from (jsonl_tables(journal) if kept is None else kept)

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
            pending.append(conform_table(table, schema))
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
    >>> from slamq.results.formats import read_results
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
            yield from parquet_rows(self.path, list(columns))
        for rec in iter_jsonl(self._append_to):
            yield {k: rec.get(k) for k in columns}

    def done(self) -> Iterator[tuple[tuple[str, str, str, str], dict[str, Any]]]:
        """``(key, record)`` of every stored run (its last row), read from the file again
        as it is iterated; the record holds the key columns and ``hash, config,
        trajectory, groundtruth, gt_map, relations, error``."""
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
            lines.append(dumps_record(rec))
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
