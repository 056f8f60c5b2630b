"""The study of a ground-truth benchmark run: how each no-reference metric agrees with the
exact truth (docs/validity.md, "The ground-truth benchmark").

A benchmark is a ``slamq run`` of generated sequences (``synth:`` recipes of
:mod:`slamq.synth.benchmark`, e.g. examples/benchmark.yaml); every run is scored against
its exact path and map. :func:`load_benchmark` reads the scored runs back with each
sequence's recipe, :func:`study_benchmark` measures each metric against the truth, and
:func:`markdown_benchmark` writes the tables.

``python studies/benchmark_study.py OUTPUT --markdown docs/validity.md`` regenerates the
section of docs/validity.md.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from _common import print_or_write_section

from slamq.errors import ParamError
from slamq.results.formats import read_results
from slamq.results.validity import METRICS, validate
from slamq.synth.benchmark import world_label

__all__ = ["BROKEN_ATE_FACTOR", "BROKEN_ATE_FLOOR", "load_benchmark", "mark_broken",
           "markdown_benchmark", "study_benchmark"]

#: A run is *broken* (decided before the benchmark was run, from the ground truth alone):
#: its ATE RMSE is more than ``BROKEN_ATE_FACTOR`` times the best of its sequence and more
#: than ``BROKEN_ATE_FLOOR`` metres (so three good runs 2 cm apart are not "broken").
BROKEN_ATE_FACTOR = 3.0
BROKEN_ATE_FLOOR = 0.2


def load_benchmark(output: Path) -> pd.DataFrame:
    """The scored runs of a ``slamq run`` output folder, one row per map, with the generated
    sequences' recipe (``world``, ``kind``, ``noise``, ``sim_seed``) and ``broken``.

    Runs that produced no map are rows too (``outcome`` not ``ok``, metrics missing).
    """
    output = Path(output)
    results = output / "results.jsonl"
    if not results.is_file():
        raise ParamError(f"{results}: no results (run `slamq run` on the config first)")
    df = read_results(results)
    if "error" in df:
        df = df[df["error"].isna() | (df["error"].astype(str) == "")]
    runs = pd.read_csv(output / "runs.csv")
    runs = runs[["algorithm", "sequence", "iteration", "outcome", "wall_time", "cpu_time"]
                if "cpu_time" in runs else ["algorithm", "sequence", "iteration", "outcome"]]
    runs = runs.assign(run=runs["iteration"].astype(str)).drop(columns="iteration")
    df = runs.merge(df.assign(run=df["run"].astype(str)), on=["algorithm", "sequence", "run"],
                    how="left")
    info = {}
    for seq in df["sequence"].unique():
        try:
            r = json.loads((output / "sequences" / seq / "recipe.json").read_text())
        except (OSError, ValueError):
            continue
        w = r["world"]
        info[seq] = {"world": world_label(w), "kind": w.get("kind", "map"),
                     "noise": r["noise"], "sim_seed": r["seed"]}
    extra = pd.DataFrame.from_dict(info, orient="index")
    df = df.merge(extra, left_on="sequence", right_index=True, how="left")
    return mark_broken(df)


def mark_broken(df: pd.DataFrame) -> pd.DataFrame:
    """``df`` with ``broken`` set from its ``ate_rmse``, sequence by sequence (the rule of
    :data:`BROKEN_ATE_FACTOR` and :data:`BROKEN_ATE_FLOOR`).

    Examples
    --------
    >>> d = pd.DataFrame({"sequence": "s", "ate_rmse": [0.05, 0.1, 0.3]})
    >>> mark_broken(d)["broken"].tolist()
    [False, False, True]
    """
    best = df.groupby("sequence")["ate_rmse"].transform("min")
    df["broken"] = (df["ate_rmse"] > BROKEN_ATE_FACTOR * best) & \
        (df["ate_rmse"] > BROKEN_ATE_FLOOR)
    return df


def _pooled_rows(df: pd.DataFrame, permutations: int, seed: int) -> pd.DataFrame:
    t = validate(df, truths=("ate_rmse", "gt_f1"), permutations=permutations, seed=seed)
    return t[t["sequence"] == "(pooled)"]


def study_benchmark(df: pd.DataFrame, *, permutations: int = 1000,
                    seed: int = 0) -> dict[str, pd.DataFrame]:
    """The tables of docs/validity.md's benchmark section, from :func:`load_benchmark`.

    ``runs``: per algorithm and noise, runs, ok, ATE and GT-map F1 (mean, std);
    ``pooled``: each metric's agreement with ATE and with F1 over every sequence;
    ``by_kind`` / ``by_world`` / ``by_noise``: the pooled concordance within each;
    ``failures``: per metric, over the sequences with a broken and an unbroken map, the
    share where the metric's worst map is broken (it sees the failure) and where its best
    map is broken (it would pick the broken one).
    """
    ok = df[df["outcome"] == "ok"]
    g = df.groupby(["algorithm", "noise"], dropna=False)
    runs = pd.DataFrame({
        "runs": g.size(), "ok": g["outcome"].apply(lambda s: int((s == "ok").sum())),
        "ate_mean": g["ate_rmse"].mean(), "ate_std": g["ate_rmse"].std(),
        "ate_median": g["ate_rmse"].median(),
        "f1_mean": g["gt_f1"].mean(), "f1_std": g["gt_f1"].std(),
        "broken": g["broken"].sum(),
    }).reset_index()
    best = ok.loc[ok.groupby("sequence")["ate_rmse"].idxmin().dropna(), "algorithm"]
    runs["best_ate_share"] = [float((best == a).mean()) if len(best) else float("nan")
                              for a in runs["algorithm"]]
    broken = df.pivot_table(index="kind", columns="noise", values="broken", aggfunc="sum",
                            fill_value=0)
    tables = {"runs": runs, "broken": broken, "pooled": _pooled_rows(ok, permutations, seed)}
    for by in ("kind", "noise", "world"):
        parts = []
        for value, part in ok.groupby(by):
            rows = _pooled_rows(part, 0, seed).assign(**{by: value})
            parts.append(rows)
        tables[f"by_{by}"] = pd.concat(parts, ignore_index=True) if parts else pd.DataFrame()
    fails = []
    for metric in METRICS:
        if metric not in ok:
            continue
        seen = picked = n = 0
        for _, part in ok.groupby("sequence"):
            part = part[np.isfinite(pd.to_numeric(part[metric], errors="coerce"))]
            if len(part) < 2 or not part["broken"].any() or part["broken"].all():
                continue
            n += 1
            order = part.sort_values(metric, kind="stable")
            seen += bool(order["broken"].iloc[-1])
            picked += bool(order["broken"].iloc[0])
        fails.append({"metric": metric, "sequences": n,
                      "worst_is_broken": seen / n if n else float("nan"),
                      "best_is_broken": picked / n if n else float("nan")})
    tables["failures"] = pd.DataFrame(fails)
    return tables


def _fmt(x: Any, spec: str = ".2f") -> str:
    try:
        return "-" if x is None or not np.isfinite(float(x)) else format(float(x), spec)
    except (TypeError, ValueError):
        return str(x)


def markdown_benchmark(tables: dict[str, pd.DataFrame], command: str) -> str:
    """The benchmark section of docs/validity.md (between ``<!-- benchmark:begin -->`` and
    ``<!-- benchmark:end -->``)."""
    lines = [f"Regenerate with `{command}`.", "",
             "### Runs", "",
             "ATE RMSE and GT-map F1: mean ± std over the runs; median ATE; best ATE: the share "
             "of all sequences on which the algorithm had the lowest ATE.", "",
             "| algorithm | odometry noise | runs | ok | broken | ATE RMSE (m) | median ATE (m) "
             "| GT-map F1 | best ATE |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in tables["runs"].itertuples():
        lines.append(f"| {r.algorithm} | {r.noise} | {r.runs} | {r.ok} | {int(r.broken)} | "
                     f"{_fmt(r.ate_mean, '.3f')} ± {_fmt(r.ate_std, '.3f')} | "
                     f"{_fmt(r.ate_median, '.3f')} | {_fmt(r.f1_mean)} ± {_fmt(r.f1_std)} | "
                     f"{_fmt(r.best_ate_share)} |")
    b = tables["broken"]
    if not b.empty:
        lines += ["", "Broken runs by world kind and odometry noise (3 programs x 3 seeds x "
                  "the worlds of the kind):", "",
                  "| world kind | " + " | ".join(str(c) for c in b.columns) + " |",
                  "|---|" + "---|" * len(b.columns)]
        for kind, row in b.iterrows():
            lines.append(f"| {kind} | " + " | ".join(str(int(v)) for v in row) + " |")
    lines += ["", "### Each metric against the truth, pooled over every sequence", "",
              "Spearman correlation (+1: the metric orders a sequence's maps as the truth does) "
              "/ pairwise concordance (0.5 = chance) / permutation p.", "",
              "| metric | vs ATE RMSE | vs GT-map F1 |", "|---|---|---|"]
    pooled = tables["pooled"]
    for metric, part in pooled.groupby("metric", sort=False):
        cells = []
        for truth in ("ate_rmse", "gt_f1"):
            row = part[part["truth"] == truth]
            if row.empty:
                cells.append("-")
                continue
            r = row.iloc[0]
            cells.append(f"{r['spearman']:+.2f} / {_fmt(r['concordance'])} / "
                         f"{_fmt(r['p_value'], '.3f')} (n={int(r['n'])})")
        lines.append(f"| {metric} | " + " | ".join(cells) + " |")
    for by, title in (("kind", "world kind"), ("noise", "odometry noise")):
        t = tables[f"by_{by}"]
        if t.empty:
            continue
        values = list(dict.fromkeys(t[by]))
        lines += ["", f"### Concordance by {title} (vs ATE RMSE / vs GT-map F1)", "",
                  "| metric | " + " | ".join(str(v) for v in values) + " |",
                  "|---|" + "---|" * len(values)]
        for metric, part in t.groupby("metric", sort=False):
            cells = []
            for v in values:
                sub = part[part[by] == v]
                c = [_fmt(sub.loc[sub["truth"] == tr, "concordance"].iloc[0])
                     if (sub["truth"] == tr).any() else "-" for tr in ("ate_rmse", "gt_f1")]
                cells.append(" / ".join(c))
            lines.append(f"| {metric} | " + " | ".join(cells) + " |")
    f = tables["failures"]
    lines += ["", "### Failures each metric sees", "",
              f"A map is broken when its ATE RMSE is over {BROKEN_ATE_FACTOR:g}x the best of "
              f"its sequence and over {BROKEN_ATE_FLOOR:g} m (decided before the run). Over "
              "the sequences with a broken and an unbroken map: how often the metric's worst "
              "map is a broken one (it sees the failure), and how often its best is (it would "
              "name a broken map best).", "",
              "| metric | sequences | worst is broken | best is broken |", "|---|---|---|---|"]
    for r in f.itertuples():
        lines.append(f"| {r.metric} | {r.sequences} | {_fmt(r.worst_is_broken)} | "
                     f"{_fmt(r.best_is_broken)} |")
    return "\n".join(lines) + "\n"


BEGIN, END = "<!-- benchmark:begin -->", "<!-- benchmark:end -->"


def main(argv: Sequence[str] | None = None) -> int:
    """``python studies/benchmark_study.py OUTPUT``: the study of a benchmark run, printed or
    written into a Markdown file between the ``<!-- benchmark:begin/end -->`` markers."""
    import argparse

    ap = argparse.ArgumentParser(prog="python studies/benchmark_study.py",
                                 description=main.__doc__)
    ap.add_argument("output", type=Path, help="the `slamq run` output folder")
    ap.add_argument("--permutations", type=int, default=1000)
    ap.add_argument("--markdown", type=Path, help="file whose marked section to replace")
    args = ap.parse_args(argv)
    tables = study_benchmark(load_benchmark(args.output), permutations=args.permutations)
    command = f"python studies/benchmark_study.py {args.output} --permutations " \
        f"{args.permutations}" + (f" --markdown {args.markdown}" if args.markdown else "")
    return print_or_write_section(markdown_benchmark(tables, command), args.markdown, BEGIN,
                                  END)


if __name__ == "__main__":
    raise SystemExit(main())
