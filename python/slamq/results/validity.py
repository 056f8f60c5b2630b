"""Measured validity: how well each no-reference map metric agrees with ground truth.

For the sequences of a results file that have ground truth (``ate_rmse`` from trajectories,
``gt_chamfer`` / ``gt_f1`` from a ground-truth map), :func:`validate` ranks the maps of each
sequence by a metric and by the ground-truth figure and reports, per sequence and pooled:

- ``spearman``: Spearman's rank correlation, signed so that +1 means "the metric orders the
  maps as the ground truth does" (the paper's metrics and ATE/chamfer are lower-is-better;
  F1 is higher-is-better, so its sign is flipped);
- ``concordance``: the share of map pairs (within one sequence; pairs tied on either side
  left out) that the metric and the ground truth order the same way (0.5 = chance);
- ``p_value``: a permutation test of the Spearman correlation (the ground truth shuffled within each
  sequence; two-sided, ``(1 + hits) / (1 + permutations)``).

The pooled ``spearman`` is the mean of the per-sequence ones weighted by their map
counts; its permutation test shuffles within every sequence at once. Sequences with fewer
than 3 scored maps are left out.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from typing import Any

import numpy as np
import pandas as pd

from slamq.columns import shown, shown_names

__all__ = ["METRICS", "TRUTHS", "validate"]

#: The no-reference metrics whose validity is measured (all lower-is-better): the columns
#: shown at ``validity`` (:data:`slamq.columns.COLUMNS`).
METRICS = shown_names("validity")


class _Truths(Mapping[str, bool]):
    """The ground-truth figures (the columns shown at ``truth``) and whether higher is
    better, as the table is now."""

    def _now(self) -> dict[str, bool]:
        return {c.name: c.higher for c in shown("truth")}

    def __getitem__(self, name: str) -> bool:
        return self._now()[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._now())

    def __len__(self) -> int:
        return len(self._now())

    def __repr__(self) -> str:
        return repr(self._now())


#: Ground-truth figures and whether higher is better.
TRUTHS: Mapping[str, bool] = _Truths()
#: Measured once and shipped (README "What the numbers mean", docs/validity.md): each
#: metric's pooled pairwise concordance (0.5 = chance) with ATE on slam_comparison_tools
#: (3 worlds x 5 algorithms) and with the damage's severity in the synthetic study
#: (studies/damage_study.py, on :mod:`slamq.synth.damage`: drift, wall doubling, rotation,
#: where the ideal is no change, and specks). The report prints it beside the figures of
#: its own results.
SHIPPED_CONCORDANCE = {
    # metric: (vs ATE, drift, doubling, rotation, specks)
    "corners": (0.73, 1.00, 0.90, 0.95, 0.98),
    "corners_canonical": (0.73, 0.97, 0.93, 0.67, 0.82),
    "occupied_fraction": (0.50, 0.03, 0.77, 0.05, 1.00),
    "proportion": (0.50, 0.00, 0.80, 0.00, 1.00),
    "enclosed_areas": (0.27, 0.20, 0.63, 0.07, 0.42),
}
#: A sequence needs this many scored maps to count.
MIN_MAPS = 3


def _ranks(x: np.ndarray) -> np.ndarray:
    """Average ranks (1-based; ties share the mean of their positions), as pandas'
    ``rank(method="average")`` of finite values.

    >>> _ranks(np.array([3.0, 1.0, 3.0, 2.0])).tolist()
    [3.5, 1.0, 3.5, 2.0]
    """
    x = np.asarray(x, dtype=float)
    order = np.argsort(x, kind="stable")
    xs = x[order]
    starts = np.r_[True, xs[1:] != xs[:-1]]
    first = np.flatnonzero(starts)
    last = np.r_[first[1:], len(x)] - 1
    ranks = np.empty(len(x))
    ranks[order] = ((first + last) / 2.0 + 1.0)[np.cumsum(starts) - 1]
    return ranks


def _centred_ranks(x: np.ndarray) -> np.ndarray:
    r = _ranks(x)
    return r - r.mean()


def _spearman_centred(ra: np.ndarray, rb: np.ndarray) -> float:
    den = float(np.sqrt((ra * ra).sum() * (rb * rb).sum()))
    return float((ra * rb).sum() / den) if den > 0 else float("nan")


def _spearman(a: np.ndarray, b: np.ndarray) -> float:
    return _spearman_centred(_centred_ranks(a), _centred_ranks(b))


def _concordance(a: np.ndarray, b: np.ndarray) -> tuple[int, int]:
    da = np.sign(a[:, None] - a[None, :])
    db = np.sign(b[:, None] - b[None, :])
    upper = np.triu(np.ones_like(da, dtype=bool), 1)
    counted = upper & (da != 0) & (db != 0)
    return int((counted & (da == db)).sum()), int(counted.sum())


def validate(results: Any, *, truths: tuple[str, ...] | None = None,
             permutations: int = 2000, seed: int = 0,
             metrics: tuple[str, ...] | None = None) -> pd.DataFrame:
    """Rank correlation of each no-reference metric with each ground-truth figure.

    Parameters
    ----------
    results : path or pandas.DataFrame
        A results file (``slamq batch``, ``slamq eval``) or its records; rows with an
        ``error`` are left out, and reference maps (algorithm ``ground_truth``...) too.
    truths : tuple of str, optional
        Ground-truth columns to use (default: those of :data:`TRUTHS` present).
    permutations : int, default 2000
        Shuffles for the p-value (0: no p-value).
    seed : int, default 0
        Seed of the shuffles (results are reproducible).
    metrics : tuple of str, optional
        Lower-is-better columns to measure (default: :data:`METRICS`).

    Returns
    -------
    pandas.DataFrame
        One row per (metric, truth, sequence) and one ``sequence="(pooled)"`` row per
        (metric, truth): ``n`` maps, ``spearman``, ``concordance``, ``pairs``, ``p_value``.

    Examples
    --------
    >>> import pandas as pd
    >>> df = pd.DataFrame({"sequence": "s", "algorithm": list("abcd"),
    ...                    "corners": [10, 20, 30, 40], "ate_rmse": [0.1, 0.3, 0.2, 0.9]})
    >>> row = validate(df, permutations=0).iloc[0]
    >>> row["metric"], row["truth"], row["sequence"], int(row["n"]), float(row["spearman"])
    ('corners', 'ate_rmse', 's', 4, 0.8)
    >>> round(float(row["concordance"]), 4)  # 5 of the 6 pairs in the same order
    0.8333
    """
    from slamq.results.columns import GROUND_TRUTH_ALGORITHMS
    from slamq.results.formats import read_results

    df = results if isinstance(results, pd.DataFrame) else read_results(results)
    if "error" in df:
        df = df[df["error"].isna() | (df["error"].astype(str) == "")]
    if "algorithm" in df:
        df = df[~df["algorithm"].astype(str).str.lower().isin(GROUND_TRUTH_ALGORITHMS)]
    if truths is None:
        truths = tuple(t for t in TRUTHS if t in df)
    rng = np.random.default_rng(seed)
    rows = []
    parts: list[Any] = []  # the sequences (grouped once, when first needed)
    numbers: dict[tuple[int, str], np.ndarray] = {}  # (sequence, column): its numbers

    def column(i: int, name: str) -> np.ndarray:
        if (i, name) not in numbers:
            numbers[(i, name)] = pd.to_numeric(parts[i][1][name], errors="coerce"
                                               ).to_numpy(dtype=float)
        return numbers[(i, name)]

    for truth in truths:
        sign = -1.0 if TRUTHS.get(truth, False) else 1.0
        for metric in METRICS if metrics is None else metrics:
            if metric not in df or truth not in df:
                continue
            groups = []
            if not parts:
                parts = list(df.groupby("sequence", sort=True))
            for i, (seq, _) in enumerate(parts):
                a, b = column(i, metric), column(i, truth)
                keep = np.isfinite(a) & np.isfinite(b)
                if keep.sum() >= MIN_MAPS:
                    groups.append((str(seq), a[keep], sign * b[keep]))
            if not groups:
                continue
            stats = []
            for seq, a, b in groups:
                rho = _spearman(a, b)
                same, pairs = _concordance(a, b)
                p = _p_value([(a, b)], rng, permutations)
                rows.append({"metric": metric, "truth": truth, "sequence": seq,
                             "n": len(a), "spearman": rho,
                             "concordance": same / pairs if pairs else float("nan"),
                             "pairs": pairs, "p_value": p})
                stats.append((rho, same, pairs, len(a)))
            n = sum(s[3] for s in stats)
            pooled = _pooled([(a, b) for _, a, b in groups])
            same = sum(s[1] for s in stats)
            pairs = sum(s[2] for s in stats)
            rows.append({"metric": metric, "truth": truth, "sequence": "(pooled)", "n": n,
                         "spearman": pooled,
                         "concordance": same / pairs if pairs else float("nan"),
                         "pairs": pairs,
                         "p_value": _p_value([(a, b) for _, a, b in groups], rng,
                                             permutations)})
    return pd.DataFrame(rows, columns=["metric", "truth", "sequence", "n", "spearman",
                                       "concordance", "pairs", "p_value"])


def _pooled(groups: list[tuple[np.ndarray, np.ndarray]]) -> float:
    return _pooled_centred([(_centred_ranks(a), _centred_ranks(b)) for a, b in groups])


def _pooled_centred(groups: list[tuple[np.ndarray, np.ndarray]]) -> float:
    rhos = [(_spearman_centred(ra, rb), len(ra)) for ra, rb in groups]
    rhos = [(r, n) for r, n in rhos if np.isfinite(r)]
    if not rhos:
        return float("nan")
    return float(sum(r * n for r, n in rhos) / sum(n for _, n in rhos))


def _p_value(groups: list[tuple[np.ndarray, np.ndarray]], rng: np.random.Generator,
             permutations: int) -> float:
    if permutations <= 0:
        return float("nan")
    # Ranks are taken once: the ranks of a shuffled column are its ranks shuffled the same
    # way, and rng.permutation(n) draws the same order as rng.permutation(b) did (one
    # shuffle of n items), so the p-values are those of shuffling the values themselves.
    centred = [(_centred_ranks(a), _centred_ranks(b)) for a, b in groups]
    observed = abs(_pooled_centred(centred))
    if not np.isfinite(observed):
        return float("nan")
    # the shuffles drawn in the order the loop over them would draw them, then every
    # shuffle's correlation at once (a group whose ranks do not vary has none in any shuffle)
    sizes = {len(rb) for _, rb in centred}
    if len(sizes) == 1:
        # groups of one size: Generator.permuted shuffles each row of a table of aranges as
        # rng.permutation would, one after the other (the same draws, the same state after),
        # about a hundred times faster than a call per shuffle
        (n,) = sizes
        g = len(centred)
        table = np.tile(np.arange(n, dtype=np.intp), (permutations * g, 1))
        drawn = rng.permuted(table, axis=1).reshape(permutations, g, n)
        orders = [drawn[:, i, :] for i in range(g)]
    else:
        orders = [np.empty((permutations, len(rb)), dtype=np.intp) for _, rb in centred]
        for k in range(permutations):
            for i, (_, rb) in enumerate(centred):
                orders[i][k] = rng.permutation(len(rb))
    total: Any = 0
    count = 0
    for (ra, rb), order in zip(centred, orders):
        den = float(np.sqrt((ra * ra).sum() * (rb * rb).sum()))
        if not den > 0:
            continue
        total = total + (rb[order] * ra).sum(axis=1) / den * len(ra)
        count += len(ra)
    hits = int((np.abs(total / count) >= observed - 1e-12).sum())
    return (1 + hits) / (1 + permutations)
