"""The columns of a results record, the one JSON cleaner, and the settings check.

A record is one map of a batch (or of ``slamq eval``): where it belongs (:data:`RUN_COLUMNS`),
its metrics (:data:`QUALITY_COLUMNS`, the keys of ``MapQuality.to_dict()`` with the
parameters as ``param_*``), its trajectory error (:data:`ATE_COLUMNS`), and its comparison
with the sequence's ground-truth map (:data:`GT_COLUMNS`). The columns, their order and
types are :data:`slamq.columns.COLUMNS`'s; these names are live views of it (registered
columns included).
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Iterable
from typing import Any

from slamq.columns import group_names, group_view, record_columns

__all__ = [
    "ATE_COLUMNS",
    "ATE_STATS",
    "GT_COLUMNS",
    "KEY",
    "PARAM_COLUMNS",
    "QUALITY_COLUMNS",
    "GROUND_TRUTH_ALGORITHMS",
    "RUN_COLUMNS",
    "columns",
    "json_value",
    "settings_difference",
]

#: A record's identity: the last record of a key wins in a results file.
KEY = ("algorithm", "sequence", "run", "map")
#: The statistics of the trajectory error (``ate_<stat>``), as :func:`slamq.ate` names them.
ATE_STATS = tuple(n.removeprefix("ate_") for n in group_names("ate") if n != "ate_error")
#: "Algorithms" whose maps are the ground truth of their sequence (beside the runs):
#: compared with, shown, never ranked.
GROUND_TRUTH_ALGORITHMS = frozenset({"ground_truth", "groundtruth", "gt", "reference"})

#: Where the map belongs, and how the record was made.
RUN_COLUMNS = group_view("run")
#: The map parameters, ``param_<name>``.
PARAM_COLUMNS = group_view("param")
#: Every key of ``MapQuality.to_dict()`` (``curve`` is dropped unless asked for).
QUALITY_COLUMNS = group_view("map", "param")
#: Trajectory error against ground truth (SPEC section 6), when both are known.
ATE_COLUMNS = group_view("ate")
#: The map against its sequence's ground-truth map (SPEC section 7), when there is one.
GT_COLUMNS = group_view("gt")


def columns(curve: bool = False) -> tuple[str, ...]:
    """The record keys, in order (``curve`` only when asked for).

    Examples
    --------
    >>> cols = columns()
    >>> cols[:3], "corners" in cols, "curve" in cols, "ate_rmse" in cols, "gt_f1" in cols
    (('map', 'algorithm', 'sequence'), True, False, True, True)
    """
    return record_columns(curve)


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
