"""Results: record columns, files, summaries.

- :mod:`slamq.results.columns`: the columns of a record, the one JSON cleaner, and the check
  that records were computed with the same settings.
- :mod:`slamq.results.formats`: the four file formats: one reader (:func:`read_results`,
  :func:`read_records`) for every results file slamq writes (``.json``, ``.csv``,
  ``.jsonl``, ``.parquet``) and the ``slamq eval`` writers.
- :mod:`slamq.results.store`: :class:`ResultsFile`, the resumable batch writer (journal,
  lock, compaction, key digests).
- :mod:`slamq.results.summary`: :func:`summarize`, mean and std per (algorithm, sequence)
  (:func:`summary_rows`: the same as plain rows, without pandas).
- :mod:`slamq.results.table`: the terminal table of ``slamq eval``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from slamq.lazy import exports

if TYPE_CHECKING:
    from slamq.results.formats import read_records, read_results, write_csv, write_json
    from slamq.results.store import ResultsFile
    from slamq.results.summary import summarize, summary_rows, summary_table

#: Public names, imported on first use: name -> module.
_WHERE = {
    "ResultsFile": "slamq.results.store",
    "read_records": "slamq.results.formats",
    "read_results": "slamq.results.formats",
    "summarize": "slamq.results.summary",
    "summary_rows": "slamq.results.summary",
    "summary_table": "slamq.results.summary",
    "write_csv": "slamq.results.formats",
    "write_json": "slamq.results.formats",
}

__getattr__, __dir__ = exports(globals(), _WHERE)

__all__ = [
    "ResultsFile",
    "read_records",
    "read_results",
    "summarize",
    "summary_rows",
    "summary_table",
    "write_csv",
    "write_json",
]
