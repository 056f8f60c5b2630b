"""The verdict: which algorithm is best on each sequence, on what basis, and the evidence
the report draws. Both ``slamq verdict`` and the report call this layer; it reads maps and
runs metrics, the report only draws what it hands over.

The rule is the one of docs/spec.md section 9 (:mod:`~slamq.verdict.rule`). Modules:

* :mod:`~slamq.verdict.records`: results files as records, and re-evaluating a record's map;
* :mod:`~slamq.verdict.rule`: the rule (:func:`~slamq.verdict.rule.sequence_verdict`);
* :mod:`~slamq.verdict.evidence`: what the maps of a sequence say about each other and the
  defect detectors, which the rule weighs without ground truth;
* :mod:`~slamq.verdict.ranking`: the ranked columns, the summary per (sequence, algorithm)
  and each sequence's ranking in the verdict's order;
* :mod:`~slamq.verdict.judge`: all of the above for a results table at once (the report's
  entry);
* :mod:`~slamq.verdict.maps`: the verdict on loose map files (``slamq verdict``);
* :mod:`~slamq.verdict.exhibits`, :mod:`~slamq.verdict.trajectory`,
  :mod:`~slamq.verdict.building`: what one map's detail page shows (the map loaded and
  scored, its counted corners and enclosed areas, defects, ground-truth comparison,
  trajectory errors, snapshots), computed here and drawn by :mod:`slamq.report`.
"""

from __future__ import annotations

import importlib
from typing import Any

__all__ = ["judge", "maps_verdict", "rank_sequence", "sequence_evidence", "sequence_verdict",
           "summarize", "verdict_sentence"]

# Loaded on first use (PEP 562): pandas only when a verdict is asked for.
_WHERE = {
    "judge": "slamq.verdict.judge",
    "maps_verdict": "slamq.verdict.maps",
    "rank_sequence": "slamq.verdict.ranking",
    "sequence_evidence": "slamq.verdict.evidence",
    "sequence_verdict": "slamq.verdict.rule",
    "summarize": "slamq.verdict.ranking",
    "verdict_sentence": "slamq.verdict.rule",
}


def __getattr__(name: str) -> Any:
    if name in _WHERE:
        return getattr(importlib.import_module(_WHERE[name]), name)
    raise AttributeError(f"module 'slamq.verdict' has no attribute {name!r}")
