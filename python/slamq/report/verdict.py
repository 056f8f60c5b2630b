"""The verdict of a report: which algorithm is best on each sequence, on what basis, and how
sure that is — written to ``verdict.json`` and said in the report's first box.

The paper's map metrics are computed exactly as it defines them, but measured against
ground truth on slam_comparison_tools (3 worlds x 5 algorithms; :mod:`slamq.results.validity`)
their pairwise concordance with the trajectory error differs widely (README, "What the
numbers mean"): corners 0.73, occupied fraction and proportion 0.50 (chance), enclosed areas
0.27 (inverted). The
ground-truth map figures agree far better (Spearman with ATE, pooled: GT F1 -0.86, GT
chamfer +0.90). So the verdict ranks by, in this order:

1. the ATE RMSE, when at least two algorithms of the sequence have one (ground truth);
2. else the GT F1 against the sequence's ground-truth map (ties: GT chamfer);
3. else corners alone, which separate broken maps from good ones but do not order good
   maps — said as the confidence, and as "no clear winner" when the runner-up is within
   25% of the best. When the maps differ in resolution or orientation (wall angles more
   than 1 degree apart modulo 90), ``corners_canonical`` (SPEC 3a: corners of each map
   turned to its walls' direction and resampled to one resolution) replaces corners.

Occupied fraction, proportion and enclosed areas never decide. A reference map (a ground
truth beside the runs) is never ranked. A map knowing less than 80% of the area of the
sequence's most complete map (``known_area_m2``; known cells when a map has no resolution)
is never named best (a half-explored map scores "best" on every paper metric); it is ranked
after the complete ones and named in the warnings. The maps ranked by plain corners share
one resolution and orientation. An algorithm without the basis figure is not ranked (rows scored on
different figures are never mixed).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from slamq.results.columns import GROUND_TRUTH_ALGORITHMS
from slamq.results.summary import ANGLE_TOLERANCE_DEG, angle_spread, distinct_resolutions

__all__ = [
    "COMPLETE_SHARE", "CLEAR_MARGIN", "basis_name", "known_share", "sequence_verdict",
    "verdict_sentence", "write_verdicts",
]

#: A map knowing less area than this share of the sequence's most complete map is partial:
#: never named best (the ranking tables flag it too).
COMPLETE_SHARE = 0.8

#: Corners: a runner-up within this relative margin of the best means no clear winner.
CLEAR_MARGIN = 0.25

_BASES = (
    # (column, higher is better, tie-breaker column, tie-breaker higher, confidence)
    ("ate_rmse", False, "gt_f1", True,
     "high: ranked by trajectory error against the ground truth"),
    ("gt_f1", True, "gt_chamfer", False,
     "high: ranked by agreement with the ground-truth map"),
    ("corners", False, None, False,
     "low: corners separate broken maps from good ones; they do not order good maps"),
)


def known_share(block: pd.DataFrame) -> dict[str, float]:
    """Each algorithm's mean known area relative to the most complete map of the block
    (``known_area_m2_mean``, or ``known_mean`` when some map has no resolution); empty when
    fewer than two algorithms have it.

    Examples
    --------
    >>> import pandas as pd
    >>> known_share(pd.DataFrame({"known_area_m2_mean": [50.0, 100.0]}, index=["a", "b"]))
    {'a': 0.5, 'b': 1.0}
    """
    def col(name: str) -> pd.Series:
        return pd.to_numeric(block.get(name, pd.Series(dtype=float)), errors="coerce")

    area = col("known_area_m2_mean").dropna()
    known = area if len(area) == len(block) else col("known_mean").dropna()
    if len(known) < 2 or known.max() <= 0:
        return {}
    return {str(a): float(v / known.max()) for a, v in known.items()}


def _means(block: pd.DataFrame, key: str) -> pd.Series:
    col = f"{key}_mean"
    if col not in block:
        return pd.Series(dtype=float)
    values = pd.to_numeric(block[col], errors="coerce")
    return values[np.isfinite(values.to_numpy(dtype=float))]


def sequence_verdict(summary: pd.DataFrame, sequence: str) -> dict[str, Any]:
    """The verdict on one sequence of a report summary.

    Parameters
    ----------
    summary : pandas.DataFrame
        :func:`slamq.report.ranking.summarize` output (index sequence, algorithm).
    sequence : str

    Returns
    -------
    dict
        ``{"sequence", "best", "ranking", "basis", "confidence", "warnings"}``: ``best``
        is an algorithm or None, ``ranking`` the ranked algorithms best first, ``basis``
        the columns used, ``warnings`` plain sentences.

    Examples
    --------
    >>> import pandas as pd
    >>> from slamq.report.ranking import summarize
    >>> df = pd.DataFrame({"sequence": "s", "algorithm": ["a", "b", "c"],
    ...                    "corners": [300, 40, 35], "ate_rmse": [0.05, 2.0, float("nan")],
    ...                    "known": [1000, 1000, 500]})
    >>> v = sequence_verdict(summarize(df), "s")
    >>> v["best"], v["ranking"], v["basis"]
    ('a', ['a', 'b'], ['ate_rmse'])
    >>> sequence_verdict(summarize(df.drop(columns="ate_rmse")), "s")["ranking"]
    ['b', 'a', 'c']
    """
    block = summary.xs(sequence, level="sequence") if len(summary) else summary
    refs = [a for a in block.index if str(a).lower() in GROUND_TRUTH_ALGORITHMS]
    block = block.drop(index=refs)
    warnings: list[str] = []
    share = known_share(block)  # by area: comparable across resolutions; else cells
    partial = {a for a, s in share.items() if s < COMPLETE_SHARE}
    for a in sorted(partial):
        warnings.append(f"{a}'s map knows {100 * share[a]:.0f}% of the area of the most "
                        "complete map: a partial map, never named best")
    res_differ = len(distinct_resolutions(block.get("resolution_mean", []))) > 1
    turned = angle_spread(block.get("wall_angle_mean", [])) > ANGLE_TOLERANCE_DEG
    differ = " and ".join(w for w, d in (("resolution", res_differ), ("orientation", turned))
                          if d)
    for key, higher, tie, tie_higher, confidence in _BASES:
        if key == "corners" and (res_differ or turned) and len(
                _means(block, "corners_canonical")):
            key = "corners_canonical"
            warnings.append(f"the maps differ in {differ}: ranked by corners_canonical (each "
                            "map turned to its walls and resampled to one resolution) instead "
                            "of corners")
        means = _means(block, key)
        if len(means) < 2 and not (key.startswith("corners") and len(means) == 1):
            continue
        ties = _means(block, tie) if tie else pd.Series(dtype=float)

        def order_key(a: Any, means: pd.Series = means, ties: pd.Series = ties,
                      higher: bool = higher, tie_higher: bool = tie_higher) -> tuple:
            v = float(means[a])
            t = float(ties[a]) if a in ties.index else math.nan
            t = (-t if tie_higher else t) if math.isfinite(t) else math.inf
            return (str(a) in partial, -v if higher else v, t, str(a))

        ranking = [str(a) for a in sorted(means.index, key=order_key)]
        unranked = sorted(str(a) for a in block.index if a not in means.index)
        if unranked:
            warnings.append(f"not ranked, no {key}: {', '.join(unranked)}")
        best = ranking[0] if ranking and ranking[0] not in partial else None
        if key.startswith("corners"):
            warnings.append("no ground truth: occupied fraction, proportion and enclosed "
                            "areas do not decide (on slam_comparison_tools their rank "
                            "agreement with the trajectory error was at chance or inverted)")
            complete = [a for a in ranking if a not in partial]
            if len(complete) >= 2:
                first, second = float(means[complete[0]]), float(means[complete[1]])
                if second <= first * (1 + CLEAR_MARGIN):
                    confidence += (f"; no clear winner: {complete[0]} and {complete[1]} are "
                                   f"within {int(CLEAR_MARGIN * 100)}% ({first:g} and "
                                   f"{second:g} corners)")
            if key == "corners" and (res_differ or turned):
                warnings.append("the maps differ in resolution or orientation: corners are "
                                "not comparable")
                best, confidence = None, "none: the maps are not comparable"
        return {"sequence": str(sequence), "best": best, "ranking": ranking,
                "basis": [key] + ([tie] if tie and len(ties) else []),
                "confidence": confidence, "warnings": warnings}
    return {"sequence": str(sequence), "best": None, "ranking": [], "basis": [],
            "confidence": "none: nothing to rank", "warnings": warnings}


_BASIS_NAMES = {"ate_rmse": "ATE RMSE", "gt_f1": "GT F1", "corners": "corners",
                "corners_canonical": "canonical corners"}


def basis_name(key: str | None) -> str:
    """How the page names a verdict's basis column.

    Examples
    --------
    >>> basis_name("ate_rmse"), basis_name("corners_canonical")
    ('ATE RMSE', 'canonical corners')
    """
    return _BASIS_NAMES.get(str(key), str(key))


def verdict_sentence(v: dict[str, Any]) -> str:
    """The verdict as the report's one sentence.

    Examples
    --------
    >>> verdict_sentence({"sequence": "s", "best": "a", "ranking": ["a", "b"],
    ...                   "basis": ["ate_rmse"], "confidence": "high: ...", "warnings": []})
    's: a is best by ATE RMSE (of 2; confidence high: ...).'
    """
    if v["best"] is None:
        why = "; ".join(v["warnings"][:1]) or v["confidence"]
        return f"{v['sequence']}: no algorithm is named best ({why})."
    basis = basis_name(v["basis"][0])
    return (f"{v['sequence']}: {v['best']} is best by {basis} (of {len(v['ranking'])}; "
            f"confidence {v['confidence']}).")


def write_verdicts(summary: pd.DataFrame, sequences: list[str], out_dir: Path
                   ) -> list[dict[str, Any]]:
    """Write ``verdict.json`` (a list, one verdict per sequence) and return the verdicts."""
    verdicts = [sequence_verdict(summary, s) for s in sequences]
    (Path(out_dir) / "verdict.json").write_text(json.dumps(verdicts, indent=1) + "\n")
    return verdicts
