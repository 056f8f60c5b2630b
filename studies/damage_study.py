"""The study of how each no-reference metric follows a known severity of damage
(docs/validity.md, "Synthetic damage").

Every series of :func:`slamq.synth.damage.series` (floor plans of
:func:`slamq.synth.damage.floor_plan`, damaged by :func:`slamq.synth.damage.degrade`) is
scored by every metric of :data:`slamq.results.validity.METRICS` (a metric added there is
studied too) and with the plan as ground truth (``plan_f1_loss`` = 1 - F1 and
``plan_chamfer`` of :func:`slamq.compare`); :func:`study` measures their rank agreement
with the severity with :func:`slamq.validate`'s statistics.

``python studies/damage_study.py --markdown docs/validity.md`` regenerates the study's
section of docs/validity.md (``--plans``, ``--permutations``, ``--seed``, ``--map``).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from _common import print_or_write_section

from slamq.metrics.compare import compare
from slamq.metrics.evaluate import evaluate
from slamq.models import OccupancyMap
from slamq.results import validity
from slamq.sources import load_map
from slamq.synth.damage import DEGRADATIONS, SEVERITIES, floor_plan, series

__all__ = ["PLAN_FIGURES", "STUDIED", "changes", "markdown", "records", "study"]

#: The degradations the study runs by default; ``superposed``, ``smear`` and ``kinks`` were
#: added for the defect detectors (studies/defects_study.py), ``gap`` for the missing-wall
#: flags of :func:`slamq.metrics.agreement.missing_walls`.
STUDIED = ("drift", "doubling", "rotation", "specks")
#: Ground-truth columns of the study: the plan as ground truth (lower is better).
PLAN_FIGURES = ("plan_f1_loss", "plan_chamfer")


def records(plans: Sequence[OccupancyMap] | int = 3, *,
            severities: dict[str, Sequence[float]] | None = None, seed: int = 0,
            align: str = "search") -> pd.DataFrame:
    """Every map of every series scored: one row per (plan, degradation, severity).

    Parameters
    ----------
    plans : int or sequence of OccupancyMap, default 3
        Floor plans, or how many procedural ones (seeds ``seed``, ``seed + 1``...).
    severities : dict, optional
        Severities per degradation (default
        :data:`slamq.synth.damage.SEVERITIES` of the :data:`STUDIED`
        degradations; a degradation left out is not studied).
    seed : int, default 0
    align : str, default "search"
        How the maps are aligned onto the plan for ``plan_f1_loss`` / ``plan_chamfer``.

    Returns
    -------
    pandas.DataFrame
        ``degradation``, ``sequence`` (degradation/plan number), ``plan`` (its source),
        ``algorithm`` (the severity as text), ``severity``, the metrics of
        :data:`slamq.results.validity.METRICS` and :data:`PLAN_FIGURES`, and
        ``known_area_m2``.

    Examples
    --------
    >>> from slamq.synth import floor_plan
    >>> df = records([floor_plan(0, rooms=(2, 2))], severities={"specks": [0, 0.01]})
    >>> df[["severity", "plan_f1_loss"]].round(3).values.tolist()
    [[0.0, 0.0], [0.01, 0.057]]
    """
    if isinstance(plans, int):
        plans = [floor_plan(seed + k) for k in range(plans)]
    sev = {k: SEVERITIES[k] for k in STUDIED} if severities is None else severities
    rows = []
    for k, plan in enumerate(plans):
        for kind, values in sev.items():
            for s, m in series(plan, kind, values, seed=seed + k):
                # corners_canonical on (off by default): the study measures every metric
                q = evaluate(m, canonical_resolution=0.07).to_dict()
                c = compare(m, plan, align=align)
                row: dict[str, Any] = {"degradation": kind, "sequence": f"{kind}/{k}",
                                       "plan": plan.source, "algorithm": f"{s:g}",
                                       "severity": s}
                row.update({name: q[name] for name in validity.METRICS if name in q})
                row.update(plan_f1_loss=1.0 - c.f1, plan_chamfer=c.chamfer,
                           known_area_m2=m.known_count * (m.resolution or 1.0) ** 2)
                rows.append(row)
    return pd.DataFrame(rows)


def study(plans: Sequence[OccupancyMap] | int = 3, *,
          severities: dict[str, Sequence[float]] | None = None, seed: int = 0,
          permutations: int = 1000, scores: pd.DataFrame | None = None) -> pd.DataFrame:
    """Rank agreement of each metric with the severity of each kind of damage.

    +1 means the metric worsens exactly as the damage grows (what a quality metric should
    do for drift, doubling and specks); 0 means it ignores the damage (what it should do for
    a rotation, which leaves the map as good as before). Computed by
    :func:`slamq.validate` with the severity as the truth.

    Parameters
    ----------
    plans, severities, seed
        As :func:`records`.
    permutations : int, default 1000
        Shuffles for the p-values.
    scores : pandas.DataFrame, optional
        :func:`records` output to use instead of computing it.

    Returns
    -------
    pandas.DataFrame
        ``degradation``, ``metric``, ``sequence`` (one per plan, and ``(pooled)``), ``n``,
        ``spearman``, ``concordance``, ``pairs``, ``p_value``.

    Examples
    --------
    >>> from slamq.synth import floor_plan
    >>> t = study([floor_plan(0, rooms=(2, 2))], severities={"doubling": [0, 0.2, 0.8]},
    ...           permutations=0)
    >>> float(t.set_index(["metric", "sequence"]).loc[("plan_chamfer", "(pooled)"),
    ...                                               "spearman"])
    1.0
    """
    df = records(plans, severities=severities, seed=seed) if scores is None else scores
    metrics = tuple(m for m in validity.METRICS if m in df) + PLAN_FIGURES
    out = []
    for kind, part in df.groupby("degradation", sort=False):
        v = validity.validate(part.assign(error=None), truths=("severity",),
                              metrics=metrics, permutations=permutations, seed=seed)
        out.append(v.drop(columns="truth").assign(degradation=kind))
    cols = ["degradation", "metric", "sequence", "n", "spearman", "concordance", "pairs",
            "p_value"]
    return pd.concat(out, ignore_index=True)[cols] if out else pd.DataFrame(columns=cols)


def changes(scores: pd.DataFrame) -> pd.DataFrame:
    """Each metric's mean relative change from severity 0, per degradation and severity.

    Examples
    --------
    >>> import pandas as pd
    >>> df = pd.DataFrame({"degradation": "rotation", "sequence": "rotation/0",
    ...                    "severity": [0.0, 2.0], "corners": [100, 118]})
    >>> float(changes(df).loc[("rotation", 2.0), "corners"])
    0.18
    """
    metrics = [m for m in (*validity.METRICS, *PLAN_FIGURES) if m in scores]
    parts = []
    for _, seq in scores.groupby("sequence", sort=False):
        base = seq[seq["severity"] == 0][metrics].iloc[0].astype(float)
        rel = seq[metrics].astype(float).sub(base).div(base.where(base != 0))
        parts.append(rel.assign(degradation=seq["degradation"], severity=seq["severity"]))
    return pd.concat(parts).groupby(["degradation", "severity"], sort=False)[metrics].mean()


def markdown(table: pd.DataFrame, scores: pd.DataFrame, command: str) -> str:
    """The study as the Markdown section of docs/validity.md.

    Examples
    --------
    >>> from slamq.synth import floor_plan
    >>> df = records([floor_plan(0, rooms=(2, 2))], severities={"specks": [0, 0.01]})
    >>> print(markdown(study(scores=df, permutations=0), df, "cmd").splitlines()[0])
    Regenerate with `cmd`.
    """
    metrics = list(dict.fromkeys(table["metric"]))
    pooled = table[table["sequence"] == "(pooled)"].set_index(["degradation", "metric"])
    plans = list(dict.fromkeys(scores["plan"]))
    lines = [f"Regenerate with `{command}`.", "",
             f"Plans: {', '.join(f'`{p}`' for p in plans)}. Per degradation, pooled over the "
             "plans: Spearman's rho with the severity / pairwise concordance (0.5 = chance) "
             "/ permutation p; +1: the metric worsens as the damage grows; \"constant\": "
             "the metric did not move.", "",
             "| degradation (severity) | " + " | ".join(metrics) + " |",
             "|---|" + "---|" * len(metrics)]
    for kind in dict.fromkeys(table["degradation"]):
        cells = []
        for m in metrics:
            if (kind, m) not in pooled.index or not np.isfinite(pooled.loc[(kind, m),
                                                                             "spearman"]):
                cells.append("constant")
                continue
            r = pooled.loc[(kind, m)]
            p = "" if not np.isfinite(r["p_value"]) else f" / p {r['p_value']:.3f}"
            cells.append(f"{r['spearman']:+.2f} / {r['concordance']:.2f}{p}")
        lines.append(f"| {kind} ({DEGRADATIONS[kind]}) | " + " | ".join(cells) + " |")
    ch = changes(scores)
    lines += ["", "Mean over the plans of each metric's relative change from the undamaged "
              "plan (the plan figures: their mean value, 0 at severity 0):", "",
              "| degradation | severity | " + " | ".join(metrics) + " |",
              "|---|---|" + "---|" * len(metrics)]
    for (kind, s), row in ch.iterrows():
        if s == 0:
            continue
        cells = []
        for m in metrics:
            if m in PLAN_FIGURES:
                val = scores[(scores["degradation"] == kind) & (scores["severity"] == s)][
                    m].mean()
                cells.append(f"{val:.3f}")
            else:
                cells.append("n/a" if not np.isfinite(row[m]) else f"{100 * row[m]:+.0f}%")
        lines.append(f"| {kind} | {s:g} | " + " | ".join(cells) + " |")
    rot = scores[scores["degradation"] == "rotation"]
    for metric in (m for m in metrics if m.startswith("corners") and m in rot):
        sev = sorted(set(rot["severity"]) - {0.0})
        lines += ["", f"{metric} of each plan under rotation (relative to the plan):", "",
                  "| plan | " + " | ".join(f"{s:g} deg" for s in sev) + " |",
                  "|---|" + "---|" * len(sev)]
        for plan, part in rot.groupby("plan", sort=False):
            base = float(part.loc[part["severity"] == 0, metric].iloc[0])
            vals = [float(part.loc[part["severity"] == s, metric].iloc[0]) for s in sev]
            lines.append(f"| `{plan}` ({base:g}) | " + " | ".join(
                f"{100 * (v / base - 1):+.0f}%" if base else "n/a" for v in vals) + " |")
    return "\n".join(lines) + "\n"


BEGIN, END = "<!-- synth:begin -->", "<!-- synth:end -->"


def main(argv: Sequence[str] | None = None) -> int:
    """``python studies/damage_study.py``: run the study, print it or write it into a
    Markdown file between the ``<!-- synth:begin -->`` / ``<!-- synth:end -->`` markers."""
    ap = argparse.ArgumentParser(prog="python studies/damage_study.py",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--plans", type=int, default=3)
    ap.add_argument("--permutations", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--map", action="append", default=[], type=Path,
                    help="a map to use as a plan too (repeatable)")
    ap.add_argument("--markdown", type=Path, help="file whose marked section to replace")
    args = ap.parse_args(argv)
    plans = [floor_plan(args.seed + k) for k in range(args.plans)]
    plans += [load_map(m) for m in args.map]
    scores = records(plans, seed=args.seed)
    table = study(scores=scores, permutations=args.permutations, seed=args.seed)
    command = "python studies/damage_study.py" + "".join(
        f" --{k} {v}" for k, v in (("plans", args.plans), ("permutations", args.permutations),
                                   ("seed", args.seed))) + "".join(
        f" --map {m}" for m in args.map)
    if args.markdown is not None:
        command += f" --markdown {args.markdown}"
    return print_or_write_section(markdown(table, scores, command), args.markdown, BEGIN, END)




if __name__ == "__main__":
    sys.exit(main())
