"""Results: record columns, files, summaries.

- :mod:`slamq.results.columns`: the columns of a record, the one JSON cleaner, and the check
  that records were computed with the same settings.
- :mod:`slamq.results.files`: one reader (:func:`read_results`, :func:`read_records`) for
  every results file slamq writes (``.json``, ``.csv``, ``.jsonl``, ``.parquet``), the
  ``slamq eval`` writers, and :class:`ResultsFile`, the resumable batch writer.
- :mod:`slamq.results.summary`: :func:`summarize`, mean and std per (algorithm, sequence).
- :mod:`slamq.results.table`: the terminal table of ``slamq eval``.
"""

from __future__ import annotations

from slamq.results.files import ResultsFile, read_records, read_results, write_csv, write_json
from slamq.results.summary import summarize, summary_table

__all__ = [
    "ResultsFile",
    "read_records",
    "read_results",
    "summarize",
    "summary_table",
    "write_csv",
    "write_json",
]
