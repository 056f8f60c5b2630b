"""The evaluation report: one static HTML site from a results file.

``slamq report RESULTS --out DIR`` (or :func:`build_report`) writes ``DIR/index.html``:
a one-sentence verdict per sequence (``verdict.json``), per-sequence tables in the verdict's
order (mean +- std over runs, the deciding column and the best value per column marked),
plots per metric, a gallery of each algorithm's maps at both ends of the deciding column
(the plain maps), and a detail page per map (the map with its counted corners, enclosed
areas, ground-truth comparison and defects as layers switched by checkboxes, numbers, the
enclosed-area curve, the trajectory coloured by ATE, and an animation of the map being
built when snapshots exist). Nothing is fetched from the network; the folder can be zipped,
mailed or served as it is.

It draws what the verdict layer (:mod:`slamq.verdict`) hands it and reads no map and runs
no metric itself. Modules: :mod:`~slamq.report.site` (:func:`build_report`),
:mod:`~slamq.report.index` (the index page), :mod:`~slamq.report.detail` (a map's page),
:mod:`~slamq.report.export` (the tables as Markdown and LaTeX), :mod:`~slamq.report.cache`
(unchanged pages kept), :mod:`~slamq.report.markup` (the page frame, ``static/report.css``),
:mod:`~slamq.report.formatting`, :mod:`~slamq.report.plots`, :mod:`~slamq.report.overlays`,
:mod:`~slamq.report.comparison`, :mod:`~slamq.report.trajectory`,
:mod:`~slamq.report.timeline` (``slamq timeline`` and the animations).
"""

from __future__ import annotations

import importlib
from typing import Any

__all__ = ["METRICS", "Metric", "build_report", "rank_sequence", "summarize"]

# Loaded on first use (PEP 562), so that `slamq --help` and `slamq eval` do not import
# pandas and matplotlib just to register the `report` subcommand.
_WHERE = {
    "METRICS": "slamq.verdict.ranking",
    "Metric": "slamq.verdict.ranking",
    "rank_sequence": "slamq.verdict.ranking",
    "summarize": "slamq.verdict.ranking",
    "build_report": "slamq.report.site",
}


def __getattr__(name: str) -> Any:
    if name in _WHERE:
        return getattr(importlib.import_module(_WHERE[name]), name)
    raise AttributeError(f"module 'slamq.report' has no attribute {name!r}")
