"""rbpf-slam's scans at the path its map was drawn at (docs/validity.md, "rbpf-slam's
scans at the path its map was drawn at, on the generated sets").

The generated sets read rbpf-slam's ``log_estimated_path.txt`` (the particles' weighted
mean); its map is the most likely particle's, drawn at ``most_likely_path.txt``. This
study scores each rbpf-slam map against its own scans at the most likely path (crossing
share, spec 7b; split share, spec 7e), puts those figures into the set's cached evidence
(``scans_study.py``'s ``scans-evidence.pkl``) in place of the mean path's, and runs the
shipped rule on both, sequences and pairs, the truth hidden. The ATE (the truth) stays the
mean path's, as the sets' tables have it.

``python studies/rbpf_path_study.py studies/scans-benchmark-h-runs [--c2] [--travel]``:
``--c2`` for the sets whose cached evidence predates the split share in the core (B-K: their
split shares come from ``split-v300-rows.csv``). Figures at the most likely path are kept in
``OUTPUT/rbpf-ml-rows.csv`` (computed once).

``--travel`` (docs/validity.md, "rbpf-slam read wholly at its most likely path"): the
shortfalls (spec 7d) too are measured with rbpf-slam's most likely path, and every case is
judged twice, by the ATE of the mean path (the tables') and by the ATE of the path each map
is drawn at (rbpf-slam's most likely path; ``OUTPUT/rbpf-ml-travel-rows.csv``, the paths in
``OUTPUT/rbpf-ml/``, computed once).
"""

from __future__ import annotations

import argparse
import math
import pickle
import tempfile
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
import pandas as pd
import scans_study as S

RULE = (0.02, 1.5)


def _most_likely_runs(df: pd.DataFrame, folder: Path) -> Any:
    """Each rbpf-slam row of ``df`` whose run left a ``most_likely_path.txt``, with that
    path written as a TUM file in ``folder`` (``i.tum``, ``i`` the row's place among
    rbpf-slam's rows): yields ``(row, tum)``."""
    from slamq.sources.mrpt import read_mrpt_most_likely

    for i, r in enumerate(df[df["algorithm"] == "rbpf-slam"].itertuples()):
        path = Path(str(r.map)).parent / "out" / "most_likely_path.txt"
        if path.exists():
            tum = (folder / f"{i}.tum").resolve()
            read_mrpt_most_likely(path).write_tum(tum)
            yield r, tum


def most_likely_figures(df: pd.DataFrame, output: Path) -> pd.DataFrame:
    """Each rbpf-slam map's crossing share, split share and split hit share at its most
    likely path (``output/rbpf-ml-rows.csv``, computed once; again when it predates the
    hit share)."""
    from slamq.sources import load_map
    from slamq.verdict.evidence import split_hit
    from slamq.verdict.scans import record_consistency, record_split

    store = output / "rbpf-ml-rows.csv"
    if store.exists():
        out = pd.read_csv(store)
        if "split_hit_ml" in out:
            return out
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for r, tum in _most_likely_runs(df, Path(tmp)):
            rec = {"scans": r.scans, "trajectory": str(tum), "map": r.map}
            cross = record_consistency(rec, load_map(str(r.map))).to_dict()["crossing_share"]
            split = record_split(rec).to_dict()
            rows.append({"map": str(r.map), "crossing_ml": cross,
                         "split_ml": split["split_crossing"],
                         "split_hit_ml": split_hit(split)})
    out = pd.DataFrame(rows)
    out.to_csv(store, index=False)
    return out


def most_likely_paths(df: pd.DataFrame, output: Path) -> pd.DataFrame:
    """``df`` with each rbpf-slam run's ``trajectory`` at its most likely path (a TUM file in
    ``output/rbpf-ml/``) and ``ate_ml``: the ATE of the path each map is drawn at (that path
    for rbpf-slam, the row's own ``ate_rmse`` for the others), scored as the batch scores
    it (``slamq.batch.records``: SE(2) alignment, the default time gap). Rows are matched
    by their map's resolved path, so ``df`` may name its files from any folder."""
    from slamq.metrics.ate import ate
    from slamq.sources.trajectories import load_pair

    store = output / "rbpf-ml-travel-rows.csv"
    if not store.exists():
        (output / "rbpf-ml").mkdir(exist_ok=True)
        rows = []
        for r, tum in _most_likely_runs(df, output / "rbpf-ml"):
            est, gt = load_pair(tum, str(r.groundtruth), "sort")
            rows.append({"map": str(Path(str(r.map)).resolve()), "trajectory_ml": str(tum),
                         "ate_ml": float(ate(gt, est, align="se2").rmse)})
        pd.DataFrame(rows).to_csv(store, index=False)
    ml = pd.read_csv(store)
    out = df.copy()
    out["ate_ml"] = out["ate_rmse"]
    traj, err = dict(zip(ml["map"], ml["trajectory_ml"])), dict(zip(ml["map"], ml["ate_ml"]))
    key = out["map"].map(lambda m: str(Path(str(m)).resolve()) if isinstance(m, str) else "")
    hit = key.isin(traj)
    out.loc[hit, "trajectory"] = key[hit].map(traj)
    out.loc[hit, "ate_ml"] = key[hit].map(err)
    return out


def patched(cache: dict, ml: pd.DataFrame, values: dict[str, float] | None
            ) -> tuple[dict, dict[str, float] | None]:
    """The cache and split values with rbpf-slam's figures at its most likely path."""
    cross = dict(zip(ml["map"], ml["crossing_ml"]))
    split = dict(zip(ml["map"], ml["split_ml"]))
    hits = dict(zip(ml["map"], ml["split_hit_ml"]))
    out = {}
    for key, ev in cache.items():
        ev = S.with_split_hits(dict(ev))
        ev["scans"] = {m: ({**f, "crossing_share": cross[m]} if m in cross else f)
                       for m, f in ev.get("scans", {}).items()}
        algs = {}
        for a, e in ev["algorithms"].items():
            mine = [split[p] for p in e.get("defects", {}) if p in split]
            met = [hits[p] for p in e.get("defects", {}) if p in hits]
            algs[a] = ({**e, "scan_split": float(np.median(mine)),
                        "split_hit": float(np.median(met))}
                       if mine and math.isfinite(e.get("scan_split", math.nan)) else e)
        ev["algorithms"] = algs
        out[key] = ev
    vals = None if values is None else {**values, **{m: v for m, v in split.items()
                                                     if m in values}}
    return out, vals


class Set(NamedTuple):
    """One set's rows and cached evidence, as the benchmark reads rbpf-slam (its mean
    path) and with its scan figures at its most likely path (``new_cache``,
    ``new_values``)."""

    df: pd.DataFrame
    cache: dict
    figure: str
    values: dict[str, float] | None
    ml: pd.DataFrame
    new_cache: dict
    new_values: dict[str, float] | None


def load_set(output: Path, c2: bool) -> Set:
    """``output``'s scored rows and cached evidence (``scans_study.py``), with its split
    shares from ``split-v300-rows.csv`` when ``c2`` (sets B-K), and rbpf-slam's figures at
    its most likely path (:func:`most_likely_figures`, :func:`patched`)."""
    df = pd.read_csv(output / "scans-rows.csv")
    cache = pickle.loads((output / "scans-evidence.pkl").read_bytes())
    values = S.split_values(df, output, "split-v300-rows.csv") if c2 else None
    ml = most_likely_figures(df, output)
    new_cache, new_values = patched(cache, ml, values)
    return Set(df, cache, "c2" if c2 else "crossing_share", values, ml, new_cache,
               new_values)


def compare_rules(out: Path, rules: dict[str, tuple], c2: bool, *, pair: bool = False
                  ) -> list[dict]:
    """One set read both ways (rbpf-slam at its mean path, as the benchmark reads it, and
    at the path its map is drawn at, judged by that path's ATE) under each of ``rules``
    (name -> rule of ``scans_study``): per reading, the cases in the ATE top two (the
    better of two, with ``pair``) and the broken runs named under each rule; every verdict
    of another rule that differs from the first rule's is printed."""
    import copy

    df, cache, figure, values, _, new_cache, new_values = load_set(out, c2)
    df_ml = most_likely_paths(df, out)
    names = list(rules)
    rows = []
    for reading, d, c, v, truth in (("mean path", df, cache, values, "ate_rmse"),
                                    ("map's path", df_ml, new_cache, new_values, "ate_ml")):
        got = S.verdicts(d.assign(ate_ml=df_ml["ate_ml"]), truth, rules=tuple(rules.values()),
                         pair=pair, cache=copy.deepcopy(c), figure=figure, values=v)
        row = {"set": out.name, "reading": reading, "cases": len(got)}
        for name, rule in rules.items():
            col = S.rule_name(rule)
            row[f"top {name}"] = int(((got[f"rank@{col}"] <= (1 if pair else 2))
                                      & got[f"best@{col}"].notna()).sum())
            row[f"broken {name}"] = int(got[f"broken_named@{col}"].sum())
        a = S.rule_name(rules[names[0]])
        for other in names[1:]:
            b = S.rule_name(rules[other])
            for _, r in got[got[f"best@{a}"].fillna("-")
                            != got[f"best@{b}"].fillna("-")].iterrows():
                print(f"  {out.name} {reading} {other}: {r['case']} "
                      f"{r['algorithms'] if pair else ''}: {r[f'best@{a}']} (rank "
                      f"{r[f'rank@{a}']}, {r[f'ratio@{a}']:.2f}x) -> {r[f'best@{b}']} (rank "
                      f"{r[f'rank@{b}']}, {r[f'ratio@{b}']:.2f}x, broken "
                      f"{r[f'broken_named@{b}']})")
        rows.append(row)
    return rows


def compare_sets(outputs: list[Path], rules: dict[str, tuple], pairs: bool) -> None:
    """:func:`compare_rules` on each of ``outputs`` (sets B-K read with their
    ``split-v300-rows.csv``), the sequences and with ``pairs`` the pairs too: one table a
    kind, per set and reading, and its sums per reading."""
    for pair in (False, True) if pairs else (False,):
        rows = [r for out in outputs for r in compare_rules(
            out, rules, (out / "split-v300-rows.csv").exists(), pair=pair)]
        table = pd.DataFrame(rows)
        print(f"\n{'Pairs' if pair else 'Sequences'}:\n")
        print(table.to_string(index=False))
        print(table.groupby("reading").sum(numeric_only=True).to_string())


def comparison_main(argv: list[str] | None, doc: str | None, rules: dict[str, tuple]
                    ) -> int:
    """A study's command line that compares ``rules`` on sets (:func:`compare_sets`): the
    sets' outputs, and ``--pairs``."""
    ap = argparse.ArgumentParser(description=(doc or "").split("\n\n")[0])
    ap.add_argument("output", type=Path, nargs="+", help="slamq run outputs of generated sets")
    ap.add_argument("--pairs", action="store_true", help="the two-map cases too")
    a = ap.parse_args(argv)
    compare_sets(a.output, rules, a.pairs)
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    ap.add_argument("output", type=Path)
    ap.add_argument("--c2", action="store_true",
                    help="split shares from OUTPUT/split-v300-rows.csv (sets B-K)")
    ap.add_argument("--no-pairs", action="store_true",
                    help="the sequences only, not every pair of programs")
    ap.add_argument("--travel", action="store_true",
                    help="the shortfalls too at the most likely path, judged by both ATEs")
    a = ap.parse_args(argv)
    df, cache, figure, values, ml, new_cache, new_values = load_set(a.output, a.c2)
    if a.travel:
        return travel(df, most_likely_paths(df, a.output), cache, new_cache, figure, values,
                      new_values, not a.no_pairs, a.output)
    print(f"{a.output.name}: rbpf-slam maps {len(ml)}, crossing share median "
          f"{df.loc[df['algorithm'] == 'rbpf-slam', 'crossing_share'].median():.4f} (mean "
          f"path) -> {ml['crossing_ml'].median():.4f} (most likely path)")
    for pair in (False,) if a.no_pairs else (False, True):
        got: dict[str, Any] = {}
        for name, c, v in (("mean", cache, values), ("most likely", new_cache, new_values)):
            got[name] = S.verdicts(df, "ate_rmse", rules=(RULE,), pair=pair, cache=c,
                                   figure=figure, values=v)
            print(f"\n{'Pairs' if pair else 'Sequences'}, rbpf-slam at its {name} path:\n")
            print(S.verdict_table(got[name], (RULE,), pair=pair))
        col = S.rule_name(RULE)
        old, new = got["mean"], got["most likely"]
        changed = old[f"best@{col}"].fillna("-") != new[f"best@{col}"].fillna("-")
        for i in np.flatnonzero(changed.to_numpy()):
            o, n = old.iloc[i], new.iloc[i]
            print(f"    {o['case']} {o['algorithms'] if pair else ''}: {o[f'best@{col}']} "
                  f"(rank {o[f'rank@{col}']}) -> {n[f'best@{col}']} (rank "
                  f"{n[f'rank@{col}']}, {n[f'ratio@{col}']:.2f}x, broken "
                  f"{n[f'broken_named@{col}']})")
    return 0


def travel(df: pd.DataFrame, df_ml: pd.DataFrame, cache: dict, new_cache: dict, figure: str,
           values: dict[str, float] | None, new_values: dict[str, float] | None,
           pairs: bool, output: Path) -> int:
    """The shipped rule as the benchmark reads rbpf-slam (its mean path for every figure),
    with its scan figures at the most likely path (the study before), and with every figure
    there (the shortfalls too); each judged by the mean path's ATE and by the map's own
    path's. The last, the benchmark read at each map's own path, is written as
    ``output/scans-verdicts[-pairs]-map-path.csv`` (``confidence_study.py --pairs`` reads
    the pairs' file)."""
    import copy

    rb = df_ml["algorithm"] == "rbpf-slam"
    print(f"rbpf-slam ATE (median): mean path {df_ml.loc[rb, 'ate_rmse'].median():.3f} m, "
          f"most likely path {df_ml.loc[rb, 'ate_ml'].median():.3f} m")
    col = S.rule_name(RULE)
    for pair in (False, True) if pairs else (False,):
        got = {}
        for name, d, c, v in (("mean path", df, cache, values),
                              ("scans at most likely", df, new_cache, new_values),
                              ("all at most likely", df_ml, new_cache, new_values)):
            for truth in ("ate_rmse", "ate_ml"):
                # each run fills the shortfalls into its cache: a copy keeps the runs apart
                got[name, truth] = S.verdicts(d.assign(ate_ml=df_ml["ate_ml"]), truth,
                                              rules=(RULE,), pair=pair,
                                              cache=copy.deepcopy(c), figure=figure,
                                              values=v)
                judged = "the mean path" if truth == "ate_rmse" else "the map's path"
                print(f"\n{'Pairs' if pair else 'Sequences'}, {name}, judged by {judged}:\n")
                print(S.verdict_table(got[name, truth], (RULE,), pair=pair))
        base, new = got["mean path", "ate_ml"], got["all at most likely", "ate_ml"]
        new.to_csv(output / f"scans-verdicts{'-pairs' if pair else ''}-map-path.csv",
                   index=False)
        for i in range(len(base)):
            o, n = base.iloc[i], new.iloc[i]
            if str(o[f"best@{col}"]) != str(n[f"best@{col}"]) or n[f"broken_named@{col}"]:
                print(f"    {o['case']} {o['algorithms'] if pair else ''}: "
                      f"{o[f'best@{col}']} -> {n[f'best@{col}']} (rank {n[f'rank@{col}']}, "
                      f"broken {n[f'broken_named@{col}']}; by the map's path) "
                      f"{str(n.get(f'reason@{col}', ''))[:160]}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
