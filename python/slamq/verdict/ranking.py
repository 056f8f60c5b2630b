"""What the report ranks, in which direction, and how numbers are summarised and printed.

The paper's metrics are "lower is better", as it argues (Filatov et al., arXiv 1708.02354):

- ATE RMSE, section IV: "a lower value of RMSE means that the corresponding SLAM algorithm
  provide better results"; plotted on a logarithmic axis (the paper's RMSE figure).
- occupied fraction, section III.A: "The proportion of occupied cells corresponds to the
  quality of the map: the higher this proportion - the less suitable the algorithm"
  (blurred or doubled walls); plotted on a linear axis (the paper's Fig. 5).
- corners, section III.B: "the map with fewer corners is more likely to be more consistent
  and have fewer artifacts"; logarithmic axis (the paper's corner figure).
- enclosed areas, section III.C: "the more of these there are, the lower the quality of the
  map"; logarithmic axis (the paper's enclosed-area figure).

With a ground-truth map (docs/spec.md section 7) two more are ranked: ``gt_f1`` (higher is
better: the share of walls within the tolerance, both ways) and ``gt_chamfer`` (lower is
better: the mean distance between the two maps' walls, metres).

The paper also warns that the three map metrics only compare maps of similar coverage: an
incomplete map has few occupied cells, corners and enclosed areas. The report therefore
flags algorithms whose maps know far fewer cells than the others on the same sequence.

Summaries are the mean and the *sample* standard deviation (``ddof=1``) over the runs of
one (sequence, algorithm), as in the paper's Table I ("0.239 +- 0.011"); one run has no
standard deviation.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from slamq.columns import COLUMNS, Column, shown
from slamq.results.columns import GROUND_TRUTH_ALGORITHMS
from slamq.verdict.rule import (
    COMPLETE_SHARE,
    basis_name,
    known_share,
    sequence_verdict,
    verdict_sentence,
)

__all__ = [
    "AGREEMENT",
    "CANONICAL",
    "METRICS",
    "Metric",
    "SCANS",
    "SPLIT",
    "SequenceRanking",
    "rank_sequence",
    "summarize",
]


#: One ranked column of the report: a row of the column table (``key``, ``label``,
#: ``unit``, ``log``, ``why``, ``higher``, ``direction``, ``heading``).
Metric = Column
#: The ranked metrics, in table order ("lower is better" unless ``higher``): the columns
#: shown at ``ranked`` (:data:`slamq.columns.COLUMNS`; a live view).
METRICS: Sequence[Metric] = shown("ranked")
#: Shown (and marked as deciding) only where the verdict ranks by it: when the maps differ
#: in resolution or orientation (:mod:`slamq.verdict.rule`).
CANONICAL = COLUMNS["corners_canonical"]
#: Without ground truth: the median consistency of a map's walls with the other maps' of
#: the sequence (slamq.agreement); a column of the table when the verdict rests on it.
AGREEMENT = COLUMNS["agreement"]
#: Without ground truth, where the maps' own scans are known: the share of a map's beams
#: that cross its walls into free space beyond (docs/spec.md 7b); a column when the
#: verdict weighs it.
SCANS = COLUMNS["scan_crossing"]
#: Where the paths were scored against their own scans split in time (docs/spec.md 7e):
#: the split crossing share; a column when the verdict weighs it.
SPLIT = COLUMNS["scan_split"]


def summarize(ok: pd.DataFrame) -> pd.DataFrame:
    """:func:`slamq.results.summarize` of successful records, indexed for the report.

    Parameters
    ----------
    ok : pandas.DataFrame
        Successful records with ``sequence``, ``algorithm`` and the metric columns.

    Returns
    -------
    pandas.DataFrame
        Index (sequence, algorithm); the columns of :func:`slamq.results.summarize`
        (``n``, ``<key>_mean``, ``<key>_std``, ``<key>_n``), with every metric of
        :data:`METRICS` present (NaN, count 0, when no record has it).

    Examples
    --------
    >>> import pandas as pd
    >>> df = pd.DataFrame({"sequence": ["s", "s"], "algorithm": ["a", "a"],
    ...                    "corners": [10, 14], "occupied_fraction": [0.1, 0.2],
    ...                    "enclosed_areas": [1, 1], "known": [5, 5]})
    >>> s = summarize(df)
    >>> float(s.loc[("s", "a"), "corners_mean"]), round(float(s.loc[("s", "a"), "corners_std"]), 4)
    (12.0, 2.8284)
    """
    from slamq.results.summary import summarize as summarize_records

    # the report states mixed settings on its page (site.py), not as a Python warning
    summary = summarize_records(ok, check_settings=False).set_index(["sequence", "algorithm"])
    for m in METRICS:
        if f"{m.key}_n" not in summary:
            summary[f"{m.key}_n"] = 0
            summary[f"{m.key}_mean"] = math.nan
            summary[f"{m.key}_std"] = math.nan
    return summary


def _finite(frame: pd.DataFrame, key: str) -> np.ndarray:
    if key not in frame:
        return np.empty(0)
    values = pd.to_numeric(frame[key], errors="coerce").to_numpy(dtype=float)
    return values[np.isfinite(values)]


@dataclass
class SequenceRanking:
    """The ranking of the algorithms on one sequence: the verdict's order
    (:mod:`slamq.verdict.rule`), with every metric's own ranks beside it for reference.

    Attributes
    ----------
    sequence : str
    order : list of str
        Algorithms in table order: the verdict's ranking (best first), then the algorithms
        it could not rank (without the figure it ranks by), by name.
    ranked : list of str
        The verdict's ranking alone.
    winner : str or None
        The verdict's best algorithm (None when it names none).
    verdict : dict
        The sequence's verdict (:func:`slamq.verdict.rule.sequence_verdict`).
    ranks : dict
        ``ranks[metric_key][algorithm]`` = rank on that metric alone (ties share the mean
        rank), shown for reference; the verdict decides.
    best : dict
        ``best[metric_key]`` = the algorithms with the best mean on that metric.
    metrics : list of Metric
        The metrics that had values on this sequence (with :data:`CANONICAL` when the
        verdict ranks by it).
    disagree : list of Metric
        Metrics whose best algorithm is not the verdict's.
    partial : list of str
        Algorithms whose maps know less than 80% of the area of the sequence's most complete
        map (``known_area_m2``; known cells when a map has no resolution; paper III.A).
    coverage : dict
        ``coverage[algorithm]`` = its mean known area relative to the most complete map's.
    ground_truths : list of str
        Ground-truth maps in the sequence (an "algorithm" named ground_truth, groundtruth, gt
        or reference): shown beside the ranking, never ranked.
    """

    sequence: str
    order: list[str]
    ranked: list[str]
    winner: str | None
    verdict: dict
    ranks: dict[str, dict[str, float]]
    best: dict[str, list[str]]
    metrics: list[Metric]
    disagree: list[Metric]
    partial: list[str]
    ground_truths: list[str] = field(default_factory=list)
    coverage: dict[str, float] = field(default_factory=dict)

    @property
    def basis(self) -> str | None:
        """The column the verdict ranks by (None when it ranks nothing)."""
        return self.verdict["basis"][0] if self.verdict.get("basis") else None

    def sentence(self) -> str:
        """One plain-text sentence: the verdict, and the other columns whose best value
        belongs to another algorithm (shown for reference; only a tie-breaker of the
        verdict's, such as GT F1 after ATE RMSE, decides anything among them).

        Examples
        --------
        >>> import pandas as pd
        >>> df = pd.DataFrame({"sequence": "s", "algorithm": ["a", "b"], "corners": [1, 9],
        ...                    "occupied_fraction": [0.2, 0.1], "enclosed_areas": [0, 3]})
        >>> print(rank_sequence(summarize(df), "s").sentence())  # doctest: +NORMALIZE_WHITESPACE
        s: a is best by corners (the verdict; the table is in its order); other columns
        order differently (lowest occupied fraction: b).
        """
        if not self.order:
            return f"{self.sequence}: no successful run to rank."
        if len(self.order) == 1:
            return f"{self.sequence}: only {self.order[0]} ran here; nothing to compare."
        if self.winner is None:
            return verdict_sentence(self.verdict)
        lead = (f"{self.sequence}: {self.winner} is best by {basis_name(self.basis)} "
                "(the verdict; the table is in its order)")
        others = [m for m in self.disagree if m.key != self.basis]
        if not others:
            return lead + "."
        parts = [f"{'highest' if m.higher else 'lowest'} {m.label}: "
                 f"{', '.join(self.best[m.key])}" for m in others]
        return lead + "; other columns order differently (" + "; ".join(parts) + ")."


def _join(parts: list[str]) -> str:
    if len(parts) <= 1:
        return "".join(parts)
    return ", ".join(parts[:-1]) + " and " + parts[-1]


def rank_sequence(summary: pd.DataFrame, sequence: str, verdict: dict | None = None
                  ) -> SequenceRanking:
    """Rank the algorithms of one sequence as its verdict does, with each metric's own
    ranks beside it.

    The order is the verdict's ranking (:func:`slamq.verdict.rule.sequence_verdict`: by
    ATE RMSE when there is ground truth, else GT F1, else corners), then the algorithms it
    could not rank, by name. On each metric with values, algorithms are also ranked by
    their mean over runs (1 = best: the lowest, or the highest for a ``higher`` metric;
    ties share the average rank) for reference; no mean over metrics is formed (occupied
    fraction, proportion and enclosed areas never decide). Ground-truth maps
    (:data:`~slamq.results.columns.GROUND_TRUTH_ALGORITHMS`) are left out. A metric
    "disagrees" when its best algorithm(s) do not include the verdict's best.

    Parameters
    ----------
    summary : pandas.DataFrame
        The output of :func:`summarize`.
    sequence : str
    verdict : dict, optional
        The sequence's verdict, when already computed.

    Returns
    -------
    SequenceRanking

    Examples
    --------
    >>> import pandas as pd
    >>> df = pd.DataFrame({"sequence": "s", "algorithm": ["a", "b"], "corners": [5, 9],
    ...                    "occupied_fraction": [0.1, 0.2], "enclosed_areas": [0, 3]})
    >>> r = rank_sequence(summarize(df), "s")
    >>> r.order, r.winner, r.disagree
    (['a', 'b'], 'a', [])
    """
    if verdict is None:
        verdict = sequence_verdict(summary, sequence)
    block = summary.xs(sequence, level="sequence") if len(summary) else summary
    ground_truths = [str(a) for a in block.index
                     if str(a).lower() in GROUND_TRUTH_ALGORITHMS]
    block = block.drop(index=ground_truths)
    algorithms = [str(a) for a in block.index]
    ranks: dict[str, dict[str, float]] = {}
    best: dict[str, list[str]] = {}
    used: list[Metric] = []
    shown = METRICS + tuple(m for m in (AGREEMENT, SCANS, SPLIT, CANONICAL)
                            if m.key in verdict["basis"])
    for m in shown:
        col = f"{m.key}_mean"
        if col not in block:
            continue
        means = pd.to_numeric(block[col], errors="coerce")
        means = means[np.isfinite(means.to_numpy(dtype=float))]
        if means.empty:
            continue
        used.append(m)
        r = means.rank(method="average", ascending=not m.higher)
        ranks[m.key] = {str(a): float(v) for a, v in r.items()}
        top = means.max() if m.higher else means.min()
        best[m.key] = sorted(str(a) for a, v in means.items() if v == top)
    ranked = [a for a in verdict["ranking"] if a in algorithms]
    order = ranked + sorted(a for a in algorithms if a not in ranked)
    winner = verdict["best"]
    disagree = [m for m in used if winner is not None and winner not in best[m.key]]
    coverage = known_share(block.loc[[a for a in block.index if str(a) in algorithms]])
    partial = sorted(a for a, v in coverage.items() if v < COMPLETE_SHARE)
    return SequenceRanking(
        sequence=str(sequence), order=order, ranked=ranked, winner=winner, verdict=verdict,
        ranks=ranks, best=best, metrics=used, disagree=disagree, partial=partial,
        ground_truths=ground_truths, coverage=coverage,
    )
