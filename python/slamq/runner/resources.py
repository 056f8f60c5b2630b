"""Each run's resources and parameter values beside its scores.

Every run's ``run.json`` holds its wall time, CPU time (user + system, of the program and
the descendants it waited for) and peak RSS. :func:`scores_frame` puts them, the values of
the swept parameters (``param.NAME`` columns) and the outcome beside the run's metrics
(``results.jsonl``): one row per run, written as ``scores.csv``; :func:`resource_summary`
adds ``wall_s``, ``cpu_s`` and ``peak_rss_mb`` mean and std over iterations to
``summary.csv``; the report's "Resources and parameters" page
(:mod:`slamq.report.resources`) plots them.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pandas as pd

__all__ = ["RESOURCE_COLUMNS", "resource_frame", "scores_frame", "resource_summary",
           "write_scores"]

#: The resource columns, seconds and MiB.
RESOURCE_COLUMNS = ("wall_s", "cpu_s", "peak_rss_mb")
_KEYS = ["algorithm", "sequence", "run"]


def resource_frame(rows: list[dict[str, Any]]) -> pd.DataFrame:
    """One row per run: who, outcome, ``wall_s``, ``cpu_s``, ``peak_rss_mb``, ``param.*``.

    Examples
    --------
    >>> f = resource_frame([{"algorithm": "a[n=5]", "program": "a", "variant": "n=5",
    ...     "params": {"n": 5}, "sequence": "s", "iteration": 1, "outcome": "ok",
    ...     "wall": 2.0, "user_cpu": 1.5, "sys_cpu": 0.25, "max_rss_kb": 2048}])
    >>> f[["run", "cpu_s", "peak_rss_mb", "param.n"]].values.tolist()
    [['1', 1.75, 2.0, 5]]
    """
    out = []
    for r in rows:
        rec: dict[str, Any] = {
            "algorithm": r.get("algorithm"), "program": r.get("program"),
            "variant": r.get("variant"), "sequence": r.get("sequence"),
            "run": str(r.get("iteration")), "outcome": r.get("outcome"),
            "wall_s": r.get("wall"),
            "cpu_s": (r["user_cpu"] + r["sys_cpu"]) if r.get("user_cpu") is not None
            and r.get("sys_cpu") is not None else None,
            "peak_rss_mb": r["max_rss_kb"] / 1024 if r.get("max_rss_kb") else None,
            "host": r.get("host"),
        }
        for k, v in (r.get("params") or {}).items():
            rec[f"param.{k}"] = v
        out.append(rec)
    frame = pd.DataFrame(out)
    for c in RESOURCE_COLUMNS:
        if c in frame:
            frame[c] = pd.to_numeric(frame[c], errors="coerce")
    return frame


def scores_frame(rows: list[dict[str, Any]], results: Any = None) -> pd.DataFrame:
    """:func:`resource_frame` joined with the runs' metrics (a results file or frame).

    Examples
    --------
    >>> rows = [{"algorithm": "a", "params": {}, "sequence": "s", "iteration": 1,
    ...          "outcome": "ok", "wall": 1.0, "user_cpu": 0.5, "sys_cpu": 0.0,
    ...          "max_rss_kb": 1024}]
    >>> res = pd.DataFrame([{"algorithm": "a", "sequence": "s", "run": "1", "ate_rmse": 0.2}])
    >>> scores_frame(rows, res)[["cpu_s", "ate_rmse"]].values.tolist()
    [[0.5, 0.2]]
    """
    frame = resource_frame(rows)
    if results is None or frame.empty:
        return frame
    if not isinstance(results, pd.DataFrame):
        from slamq.results import read_results

        if not Path(results).exists():
            return frame
        results = read_results(results)
    res = results.copy()
    for k in _KEYS:
        res[k] = res[k].astype(str)
    res = res.drop_duplicates(_KEYS, keep="last")
    res = res.drop(columns=[c for c in res.columns if c in frame.columns and c not in _KEYS])
    return frame.merge(res, on=_KEYS, how="left")


def resource_summary(summary: pd.DataFrame | None, frame: pd.DataFrame) -> pd.DataFrame | None:
    """Add ``wall_s``/``cpu_s``/``peak_rss_mb`` ``_mean`` and ``_std`` (over the runs that
    ended, any outcome) per algorithm and sequence to a summary.

    Examples
    --------
    >>> f = pd.DataFrame({"algorithm": ["a", "a"], "sequence": ["s", "s"],
    ...                   "wall_s": [1.0, 3.0], "cpu_s": [1.0, 1.0], "peak_rss_mb": [5, 7]})
    >>> s = resource_summary(pd.DataFrame({"algorithm": ["a"], "sequence": ["s"]}), f)
    >>> s[["wall_s_mean", "wall_s_std", "peak_rss_mb_mean"]].values.tolist()
    [[2.0, 1.4142135623730951, 6.0]]
    """
    if summary is None or frame.empty:
        return summary
    cols = [c for c in RESOURCE_COLUMNS if c in frame]
    stats = frame.groupby(["algorithm", "sequence"])[cols].agg(["mean", "std"])
    stats.columns = [f"{c}_{s}" for c, s in stats.columns]
    summary = summary.drop(columns=[c for c in stats.columns if c in summary], errors="ignore")
    return summary.merge(stats.reset_index(), on=["algorithm", "sequence"], how="left")


def write_scores(out: Path, rows: list[dict[str, Any]], results: Any) -> pd.DataFrame:
    """Write ``out/scores.csv`` (:func:`scores_frame`) and return the frame.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> write_scores(d, [{"algorithm": "a", "sequence": "s", "iteration": 1,
    ...                   "outcome": "crash", "wall": 0.1}], None).shape[0]
    1
    >>> (d / "scores.csv").exists()
    True
    """
    from slamq.results.summary import spreadsheet_safe

    frame = scores_frame(rows, results)
    spreadsheet_safe(frame).to_csv(out / "scores.csv", index=False)
    return frame
