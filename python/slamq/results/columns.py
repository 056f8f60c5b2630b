"""The columns of a results record, the one JSON cleaner, and the settings check.

A record is one map of a batch (or of ``slamq eval``): where it belongs (:data:`RUN_COLUMNS`),
its metrics (:data:`QUALITY_COLUMNS`, the keys of ``MapQuality.to_dict()`` with the
parameters as ``param_*``), its trajectory error (:data:`ATE_COLUMNS`), and its comparison
with the sequence's ground-truth map (:data:`GT_COLUMNS`).
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterable
from dataclasses import fields
from typing import Any

from slamq.models import MapQuality
from slamq.models.comparison import COMPARISON_FIGURES
from slamq.params import PARAM_NAMES

__all__ = [
    "ATE_COLUMNS",
    "ATE_STATS",
    "GT_COLUMNS",
    "KEY",
    "QUALITY_COLUMNS",
    "GROUND_TRUTH_ALGORITHMS",
    "RUN_COLUMNS",
    "columns",
    "json_value",
    "settings_difference",
]

#: A record's identity: the last record of a key wins in a results file.
KEY = ("algorithm", "sequence", "run", "map")
#: Where the map belongs, and how the record was made.
RUN_COLUMNS = (
    "map", "algorithm", "sequence", "run", "trajectory", "groundtruth",
    "hash", "config", "unknown_value", "error", "seconds",
)
PARAM_COLUMNS = tuple(f"param_{name}" for name in PARAM_NAMES)
#: Every key of ``MapQuality.to_dict()`` (``curve`` is dropped unless asked for).
QUALITY_COLUMNS = tuple(
    f.name for f in fields(MapQuality) if f.name != "params"
) + PARAM_COLUMNS
ATE_STATS = ("rmse", "mean", "median", "std", "min", "max", "n")
#: Trajectory error against ground truth (SPEC section 6), when both are known.
ATE_COLUMNS = tuple(f"ate_{s}" for s in ATE_STATS) + ("ate_error",)
#: The map against its sequence's ground-truth map (SPEC section 7), when there is one.
GT_COLUMNS = ("gt_map",) + tuple(f"gt_{f}" for f in COMPARISON_FIGURES) + ("gt_error",)
#: "Algorithms" whose maps are the ground truth of their sequence (beside the runs):
#: compared with, shown, never ranked.
GROUND_TRUTH_ALGORITHMS = frozenset({"ground_truth", "groundtruth", "gt", "reference"})


def columns(curve: bool = False) -> tuple[str, ...]:
    """The record keys, in order (``curve`` only when asked for).

    Examples
    --------
    >>> cols = columns()
    >>> cols[:3], "corners" in cols, "curve" in cols, "ate_rmse" in cols, "gt_f1" in cols
    (('map', 'algorithm', 'sequence'), True, False, True, True)
    """
    q = QUALITY_COLUMNS if curve else tuple(c for c in QUALITY_COLUMNS if c != "curve")
    return RUN_COLUMNS + q + ATE_COLUMNS + GT_COLUMNS


def json_value(value: Any) -> Any:
    """JSON-ready: NaN -> None, numpy scalars -> Python, paths -> str."""
    if value is None or isinstance(value, (str, bool, int)):
        return value
    if isinstance(value, float):
        return None if math.isnan(value) or math.isinf(value) else value
    if isinstance(value, (list, tuple)):
        return [json_value(v) for v in value]
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    item = getattr(value, "item", None)
    if callable(item):
        return json_value(item())
    return str(value)


def settings_difference(configs: Iterable[Any]) -> str | None:
    """Which settings differ between the ``config`` strings of some records (None when
    they are all alike).

    Examples
    --------
    >>> a = '{"params": {"min_area": 1}}'
    >>> b = '{"params": {"min_area": 3}}'
    >>> settings_difference([a, b, a]), settings_difference([a, a, None])
    ('min_area: 1, 3', None)
    """
    distinct = sorted({c for c in configs if isinstance(c, str) and c})
    if len(distinct) < 2:
        return None
    flat: list[dict[str, str]] = []
    for text in distinct:
        try:
            doc = json.loads(text)
        except ValueError:
            doc = {"config": text}
        if not isinstance(doc, dict):
            doc = {"config": doc}
        one: dict[str, str] = {}
        for key, value in doc.items():
            inner = value if isinstance(value, dict) else {key: value}
            one.update({k: json.dumps(v) for k, v in inner.items()})
        flat.append(one)
    keys = sorted({k for one in flat for k in one})
    diffs = []
    for k in keys:
        values = sorted({one.get(k, "none") for one in flat})
        if len(values) > 1:
            diffs.append(f"{k}: {', '.join(values)}")
    return "; ".join(diffs) or "config"
