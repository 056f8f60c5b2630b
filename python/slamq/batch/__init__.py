"""Batch evaluation: thousands of maps, resumable, on one machine or a Dask cluster.

Follow a batch from here:

* :mod:`slamq.batch.runs` finds the runs (:func:`discover_runs`,
  :class:`~slamq.batch.runs.Discovery`); the rules are in its docstring. It hands each
  source to :mod:`slamq.batch.layouts` (``<algorithm>/<sequence>/<run>/`` folders, flat
  ``<sequence>/<algorithm>_map.yaml`` folders, a map file named directly) or
  :mod:`slamq.batch.manifest` (manifest CSV files); :mod:`slamq.batch.pairing` pairs each
  map with its trajectory, ground truth and ground-truth map. Each run is a
  :class:`slamq.batch.run.Run`.
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
