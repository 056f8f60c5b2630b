"""Batch evaluation: thousands of maps, resumable, on one machine or a Dask cluster.

Follow a batch from here:

* :mod:`slamq.batch.runs` finds the runs (``<algorithm>/<sequence>/<run>/`` folders,
  flat ``<sequence>/<algorithm>_map.yaml`` folders, manifest CSV files) and their
  trajectories; the rules are in its docstring.
* :mod:`slamq.batch.engine` (:func:`evaluate_many`) evaluates them in parallel (thread
  pool, any ``concurrent.futures`` executor, or Dask) and streams records in input order.
* :mod:`slamq.batch.records` makes one record per map (:func:`evaluate_run`), with the
  content hash used to resume.
* :class:`slamq.results.ResultsFile` appends the records to ``.jsonl`` / ``.parquet``
  files that survive ``kill -9`` (:func:`slamq.results.read_results` reads them back), and
  :func:`slamq.results.summarize` gives mean and standard deviation per (algorithm,
  sequence), the paper's Table I.

>>> from slamq.batch import Run
>>> Run("m.yaml", "gmapping", "office").run
'0'
"""

from __future__ import annotations

from slamq.batch.engine import evaluate_chunk, evaluate_many
from slamq.batch.records import columns, content_hash, evaluate_run
from slamq.batch.runs import Run, discover_runs, read_manifest

__all__ = [
    "Run",
    "columns",
    "content_hash",
    "discover_runs",
    "evaluate_chunk",
    "evaluate_many",
    "evaluate_run",
    "read_manifest",
]
