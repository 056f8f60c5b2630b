"""Reading results for the verdict and the report, and re-evaluating a record's map when a
page needs more than its record holds.

Results are batch records (see ``slamq.batch``): one per map, with ``map``, ``algorithm``,
``sequence``, ``run``, ``trajectory``, ``groundtruth``, ``scans``, ``error`` and the metric
columns.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, Union

import pandas as pd

from slamq.errors import SlamqError
from slamq.params import PARAM_NAMES, Params

__all__ = ["ResultsLike", "evaluate_map", "load_results", "params_of", "usable"]

ResultsLike = Union[str, Path, pd.DataFrame, list]



def load_results(results: ResultsLike) -> pd.DataFrame:
    """Results as a DataFrame, from a batch results file, a DataFrame or a list of dicts.

    Files are read with :func:`slamq.results.read_results` (``.jsonl``, ``.parquet``, and
    ``.json``/``.csv`` as ``slamq eval`` writes them).
    Missing ``sequence`` becomes ``"all maps"``; missing ``algorithm`` the map's file stem;
    missing ``run`` the record's position within its (sequence, algorithm).

    Raises
    ------
    SlamqError
        The file is missing, unreadable, or holds no record with a ``map`` column.

    Examples
    --------
    >>> df = load_results([{"map": "a/gmapping.yaml", "corners": 3}])
    >>> df.loc[0, "algorithm"], df.loc[0, "sequence"], int(df.loc[0, "run"])
    ('gmapping', 'all maps', 0)
    """
    if isinstance(results, pd.DataFrame):
        frame = results.copy()
        where = "<DataFrame>"
    elif isinstance(results, list):
        frame = pd.DataFrame(results)
        where = "<records>"
    else:
        path = Path(results)
        where = str(path)
        if not path.is_file():
            raise SlamqError(f"{path}: results file not found")
        frame = _read_file(path)
    if frame.empty:
        raise SlamqError(f"{where}: no result records")
    if "map" not in frame or frame["map"].map(_missing).all():
        raise SlamqError(f"{where}: results have no 'map' column (not a slamq batch file?)")
    frame = frame.reset_index(drop=True)
    for col in ("trajectory", "groundtruth", "scans", "error"):
        if col not in frame:
            frame[col] = None
    frame["error"] = [
        "record without a map path" if _missing(m) and _missing(e) else None if _missing(e)
        else str(e) for m, e in zip(frame["map"], frame["error"])]
    frame["map"] = ["" if _missing(m) else str(m) for m in frame["map"]]
    if "algorithm" not in frame:
        frame["algorithm"] = None
    frame["algorithm"] = [
        Path(m).stem if _missing(a) else str(a) for a, m in zip(frame["algorithm"], frame["map"])
    ]
    if "sequence" not in frame:
        frame["sequence"] = None
    frame["sequence"] = ["all maps" if _missing(s) else str(s) for s in frame["sequence"]]
    if "run" not in frame:
        frame["run"] = None
    if frame["run"].map(_missing).any():
        order = frame.groupby(["sequence", "algorithm"]).cumcount()
        frame["run"] = [o if _missing(r) else r for r, o in zip(frame["run"], order)]
    return frame


def _read_file(path: Path) -> pd.DataFrame:
    from slamq.results.formats import read_results

    if path.suffix.lower() not in (".jsonl", ".ndjson", ".parquet", ".pq", ".json", ".csv"):
        raise SlamqError(f"{path}: unknown results format {path.suffix!r} "
                         "(use .jsonl, .parquet, .json or .csv)")
    try:
        return read_results(path)
    except SlamqError:
        raise
    except (OSError, ValueError) as exc:
        raise SlamqError(f"{path}: cannot read results: {exc}") from exc


def _missing(x: Any) -> bool:
    if x is None:
        return True
    if isinstance(x, float) and math.isnan(x):
        return True
    return isinstance(x, str) and x.strip() == ""


def usable(x: Any) -> bool:
    """True for a present value (not None, NaN or empty string)."""
    return not _missing(x)


def params_of(record: dict) -> Params:
    """The metric parameters a record was computed with (``param_*`` keys), else defaults.

    Examples
    --------
    >>> params_of({"param_min_area": 3}).min_area
    3
    """
    kw = {}
    for name in PARAM_NAMES:
        v = record.get(f"param_{name}")
        if usable(v):
            kw[name] = int(v) if name in ("min_dot_area", "sweep_step", "min_area") else float(v)
    return Params(**kw)


def evaluate_map(source: Any, params: Params, *, curve: bool = True):
    """``slamq.evaluate`` of a map with the parameters a record was computed with.

    Examples
    --------
    >>> import numpy as np, slamq
    >>> evaluate_map(np.full((4, 4), 254, np.uint8), slamq.Params()).corners
    0
    """
    from slamq.api import evaluate

    return evaluate(source, params=params, curve=curve)
