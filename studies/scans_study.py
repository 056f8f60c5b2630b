"""A map against its own scans (docs/spec.md 7b) on SLAM programs' maps, and the verdict
that uses it (docs/validity.md, "A map against its own scans in the verdict").

``python studies/scans_study.py benchmark OUTPUT``: every ok run of a ``slamq run`` output
of generated sequences (studies/scans-benchmark-a.yaml, -b.yaml) scored against the scans
of its sequence's rawlog at its own trajectory, beside its ATE; the concordance tables; and
the verdict with the ground truth hidden (sequences, and every pair of programs as a
two-map case).

``python studies/scans_study.py real OUTPUT``: the same for the runs of
``examples/real2d.yaml`` beside the relations error (:func:`real_rows`: the ``rel_*``
columns of ``slamq run``'s results, or an earlier pipeline's ``relations.csv``);
``real OUTPUT OTHER...`` takes the runs of several outputs as one set (the GMapping study:
``examples/real2d-runs studies/real2d-gmapping-runs``) and writes into the last.

Both write ``OUTPUT/scans-rows.csv`` (one row per run) and print Markdown; ``--no-pairs``
leaves out the two-map cases (the costly part on large real logs).
"""

from __future__ import annotations

import argparse
import itertools
import math
import re
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from slamq.metrics.scans import scan_consistency
from slamq.results.validity import validate
from slamq.sources import load_map, load_scans, load_trajectory

#: The figures of a map against its scans, lower is better (miss_share = 1 - hit_share).
FIGURES = ("violation_share", "crossing_share", "miss_share", "unknown_share")


def score_runs(runs: pd.DataFrame, *, trajectory_of: Any = None) -> pd.DataFrame:
    """``runs`` (``map``, ``scans``, ``trajectory``) with the scan figures of each map.

    ``trajectory_of(row)`` gives a row's Trajectory (default: ``load_trajectory`` of its
    ``trajectory`` column, sorted by time).
    """
    cache: dict[str, Any] = {}
    out = []
    for r in runs.to_dict("records"):
        row = dict(r)
        try:
            scans = cache.get(r["scans"])
            if scans is None:
                scans = cache[r["scans"]] = load_scans(r["scans"])
            traj = (trajectory_of(r) if trajectory_of is not None
                    else load_trajectory(r["trajectory"], unsorted="sort"))
            grid = load_map(r["map"])
            t0 = time.process_time()
            c = scan_consistency(grid, scans, traj)
            row["scan_cpu_s"] = time.process_time() - t0
            fig = c.to_dict()
            fig["scans_scored"] = fig.pop("scans")  # "scans" names the recording
            row.update(fig)
            row["miss_share"] = 1.0 - c.hit_share
            row["placed_share"] = float(c.placed.mean())
        except Exception as exc:  # noqa: BLE001 - a study row records why it failed
            row["scan_error"] = f"{type(exc).__name__}: {exc}"[:200]
        out.append(row)
    return pd.DataFrame(out)


def concordance(df: pd.DataFrame, truths: tuple[str, ...], metrics: tuple[str, ...]
                ) -> pd.DataFrame:
    """Pooled and per-group concordance of each figure with each truth (validate)."""
    return validate(df, truths=truths, permutations=1000, metrics=metrics)


def failures_seen(df: pd.DataFrame, figure: str, broken: str = "broken") -> dict[str, Any]:
    """Over the sequences with a broken and an unbroken map: how often the figure's worst
    map is a broken one, and how often its best is.

    Examples
    --------
    >>> df = pd.DataFrame({"sequence": "s", "v": [0.1, 0.4, 0.2],
    ...                    "broken": [False, True, False]})
    >>> failures_seen(df, "v")
    {'sequences': 1, 'worst_is_broken': 1, 'best_is_broken': 0}
    """
    n = worst = best = 0
    for _, b in df.dropna(subset=[figure]).groupby("sequence"):
        if not (b[broken].any() and (~b[broken]).any()):
            continue
        n += 1
        worst += bool(b.loc[b[figure].idxmax(), broken])
        best += bool(b.loc[b[figure].idxmin(), broken])
    return {"sequences": n, "worst_is_broken": worst, "best_is_broken": best}


def _fmt(x: Any, f: str = ".3f") -> str:
    return "-" if x is None or (isinstance(x, float) and not math.isfinite(x)) else format(x, f)


def tables(df: pd.DataFrame, truth: str, label: str) -> str:
    """The Markdown of the figures against ``truth``."""
    out = []
    ok = df[df.get("scan_error", pd.Series(index=df.index, dtype=object)).isna()]
    t = concordance(ok, (truth,), FIGURES)
    pooled = t[t["sequence"] == "(pooled)"]
    out.append(f"Concordance with {label} within each sequence (0.5 = chance; Spearman / "
               "concordance / permutation p, 1000 shuffles):\n")
    out.append("| figure | pooled |\n|---|---|")
    for _, r in pooled.iterrows():
        out.append(f"| {r['metric']} | {r['spearman']:+.2f} / {r['concordance']:.2f} / "
                   f"{r['p_value']:.3f} (n={int(r['n'])}) |")
    out.append("")
    if "broken" in ok:
        out.append("Broken maps (truth > 3x the sequence's best and > 0.2 m): violation "
                   "share of broken and unbroken maps, and over the sequences with both, "
                   "how often the highest violation share is a broken map's and how often "
                   "the lowest is:\n")
        b, g = ok[ok["broken"]], ok[~ok["broken"]]
        for fig in ("violation_share", "crossing_share"):
            if fig not in ok:
                continue
            seen = failures_seen(ok, fig)
            out.append(f"| maps | n | {fig}: median | min | max |\n|---|---|---|---|---|")
            for name, part in (("broken", b), ("unbroken", g)):
                v = part[fig]
                out.append(f"| {name} | {len(part)} | {_fmt(v.median())} | {_fmt(v.min())} "
                           f"| {_fmt(v.max())} |")
            out.append(f"\nSequences with both: {seen['sequences']}; highest {fig} "
                       f"broken in {seen['worst_is_broken']}, lowest broken in "
                       f"{seen['best_is_broken']}.\n")
    out.append("Per program (medians over its maps):\n")
    out.append("| program | maps | truth | violation share | crossing share | hit share | "
               "scans scored |\n|---|---|---|---|---|---|---|")
    for alg, b in ok.groupby(ok["algorithm"].astype(str).str.split("[").str[0]):
        out.append(f"| {alg} | {len(b)} | {_fmt(b[truth].median())} | "
                   f"{_fmt(b['violation_share'].median())} | "
                   f"{_fmt(b.get('crossing_share', pd.Series(dtype=float)).median())} | "
                   f"{_fmt(b['hit_share'].median())} "
                   f"| {_fmt(b['scans_scored'].median(), '.0f')} |")
    out.append("")
    out.append("| sequence | algorithm | truth | violation | crossing | hit | unknown | outside "
               "| scans | CPU s |\n|---|---|---|---|---|---|---|---|---|---|")
    for r in df.sort_values(["sequence", "algorithm"]).to_dict("records"):
        out.append(f"| {r['sequence']} | {r['algorithm']} | {_fmt(r.get(truth))} | "
                   f"{_fmt(r.get('violation_share'))} | {_fmt(r.get('crossing_share'))} | "
                   f"{_fmt(r.get('hit_share'))} | "
                   f"{_fmt(r.get('unknown_share'))} | {_fmt(r.get('outside_share'))} | "
                   f"{r.get('scans_scored', '-')} | {_fmt(r.get('scan_cpu_s'), '.2f')} |"
                   + (f" {r['scan_error']}" if isinstance(r.get("scan_error"), str) else ""))
    return "\n".join(out) + "\n"


def benchmark_rows(output: Path) -> pd.DataFrame:
    """The ok runs of a generated benchmark with their scans file and ATE."""
    sys.path.insert(0, str(Path(__file__).parent))
    from benchmark_study import load_benchmark
    from verdict_study import _with_wall_symmetry

    df = load_benchmark(output)
    df = df[(df["outcome"] == "ok") & df["map"].notna()].copy()
    df["scans"] = [str(output / "sequences" / s / f"{s}.rawlog") for s in df["sequence"]]
    # sets scored before the symmetry classes existed: measured as a scoring today gives
    return _with_wall_symmetry(df)


def real_rows(output: Path) -> pd.DataFrame:
    """The real2d runs with their relations error, map, scans and trajectory.

    From ``OUTPUT/results.jsonl`` when its records have the ``rel_*`` columns (``slamq run
    examples/real2d.yaml`` scores them since 2026-11-28); else, for an output of the
    earlier pipeline (``studies/real2d.py prepare`` / ``score`` before then), from
    ``OUTPUT/relations.csv`` with each run's ``map.yaml`` and the sorted estimate an
    earlier call of this study wrote beside it (``estimate-sorted.tum``).
    """
    from slamq.results.formats import read_results

    recs = read_results(output / "results.jsonl")
    if "rel_trans_abs_mean" in recs and recs["rel_trans_abs_mean"].notna().any():
        ok = recs[recs["error"].isna() | (recs["error"].astype(str) == "")]
        df = ok.assign(rel_trans_abs_mean=ok["rel_trans_abs_mean"],
                       rel_rot_abs_mean=ok.get("rel_rot_abs_mean"))[
            ["sequence", "algorithm", "run", "map", "scans", "trajectory",
             "rel_trans_abs_mean", "rel_rot_abs_mean"]].copy()
    else:
        rel = pd.read_csv(output / "relations.csv")
        rows = []
        for r in rel.to_dict("records"):
            folder = (output / r["algorithm"].split("[")[0] / r["variant"] / r["sequence"]
                      / str(r["iteration"]))
            if not (folder / "map.yaml").exists():
                continue
            rows.append({"sequence": r["sequence"], "algorithm": r["algorithm"],
                         "run": r["iteration"], "map": str(folder / "map.yaml"),
                         "scans": str(output / "sequences" / r["sequence"]
                                      / f"{r['sequence']}.rawlog"),
                         "trajectory": str(folder / "estimate-sorted.tum"),
                         "rel_trans_abs_mean": r["trans_abs_mean"],
                         "rel_rot_abs_mean": r["rot_abs_mean"]})
        df = pd.DataFrame(rows)
    return df


def with_broken(df: pd.DataFrame) -> pd.DataFrame:
    """``df`` with ``broken``: a run with more than 3x the best relations error of its
    sequence and iteration, and more than 0.2 m.

    Examples
    --------
    >>> df = pd.DataFrame({"sequence": "s", "run": 1, "rel_trans_abs_mean": [0.1, 0.25, 0.4]})
    >>> with_broken(df)["broken"].tolist()
    [False, False, True]
    """
    best = df.groupby(["sequence", "run"])["rel_trans_abs_mean"].transform("min")
    return df.assign(broken=(df["rel_trans_abs_mean"] > 3 * best)
                     & (df["rel_trans_abs_mean"] > 0.2))


def pairs(df: pd.DataFrame) -> list[tuple[str, pd.DataFrame]]:
    """Every pair of programs of each sequence: ``(label, rows)``.

    Examples
    --------
    >>> df = pd.DataFrame({"sequence": "s", "algorithm": ["a", "b", "c"]})
    >>> [label for label, _ in pairs(df)]
    ['s: a | b', 's: a | c', 's: b | c']
    """
    out = []
    for seq, b in df.groupby("sequence"):
        for a1, a2 in itertools.combinations(sorted(b["algorithm"].unique()), 2):
            out.append((f"{seq}: {a1} | {a2}", b[b["algorithm"].isin((a1, a2))]))
    return out


#: The (SCAN_FLOOR, SCAN_SHARE) grid the rule's veto was chosen from on set A.
GRID = tuple((v, k) for v in (0.02, 0.05, 0.10) for k in (1.5, 2.0, 3.0))
#: The margins (absolute, crossing share) the veto's third term was chosen from
#: (docs/validity.md, "A veto with a margin"): a map is vetoed only when its crossing share
#: is also more than the margin above the sequence's lowest.
MARGINS = (0.0, 0.005, 0.01, 0.02, 0.03, 0.05)


#: Veto anchors tried as F3 (docs/validity.md, "A veto anchored on the middle map"): with
#: three or more maps the limit is max(floor, K x the median crossing share).
MEDIAN_SHARES = (1.5, 2.0, 3.0)
#: A rule's element when the veto is anchored on the median (F3).
MEDIAN = "median"
#: The rules' last element when the crossing share orders the maps the agreement confirms
#: equally (F2 of docs/validity.md, "A veto with a margin"), instead of corners.
ORDER = "order"
#: The thresholds of the travel veto tried on the pool (docs/validity.md, "Paths shortened
#: along a corridor"); inf: no travel veto (the rule before it).
SHORTFALLS = (math.inf, 0.02, 0.03, 0.04, 0.05)


def rule_name(rule: tuple | None) -> str:
    """The column suffix of a rule: ``none``, ``V/K``, ``V/K/G`` (G the margin), with
    ``/order`` when the crossing share orders the confirmed maps (:data:`ORDER`).

    Examples
    --------
    >>> rule_name(None), rule_name((0.02, 1.5)), rule_name((0.02, 1.5, 0.01, ORDER))
    ('none', '0.02/1.5', '0.02/1.5/0.01/order')
    """
    return "none" if rule is None else "/".join(
        x if isinstance(x, str) else f"{x:g}" for x in rule)


def _limit_with_margin(floor: float, share: float, margin: float = 0.0,
                       median: bool = False) -> Any:
    """:func:`slamq.verdict.rule.scan_limit` with a third term, the lowest plus ``margin``
    (F1); with ``median``, three or more maps anchored on their median, not the lowest
    (F3)."""
    def limit(crossings: dict[str, float]) -> float:
        finite = [v for v in crossings.values() if math.isfinite(v)]
        if not finite:
            return math.nan
        anchor = float(np.median(finite)) if median and len(finite) >= 3 else min(finite)
        return max(floor, share * anchor, min(finite) + margin)
    return limit


def _hidden(df: pd.DataFrame) -> pd.DataFrame:
    """The rows with every ground-truth column dropped (as verdict_study does)."""
    return df.drop(columns=[c for c in df.columns if c.startswith(
        ("ate_", "gt_", "groundtruth", "rel_")) or c in ("broken",)])


def _without_scans(ev: dict[str, Any]) -> dict[str, Any]:
    """The evidence as it would be without scans (every scan figure removed, and the paths'
    shortfalls, which are weighed only where the scans say so)."""
    out = dict(ev)
    out["algorithms"] = {a: {**e, "scan_violation": math.nan, "scan_crossing": math.nan,
                             "scan_hit": math.nan, "scan_runs": 0, "scan_split": math.nan,
                             "shortfall": math.nan} for a, e in ev["algorithms"].items()}
    return out


def _scan_order(corner_key: Any, scans: dict[str, float]) -> Any:
    """``_corner_key`` of the rule with the crossing share ordering the confirmed maps
    when each of them has one (F2), else corners as before."""
    def key(block: pd.DataFrame, names: list[str]) -> tuple[str | None, pd.Series]:
        vals = {a: scans.get(a, math.nan) for a in names}
        if names and all(math.isfinite(v) for v in vals.values()):
            return "scan_crossing", pd.Series(vals, dtype=float)
        return corner_key(block, names)
    return key


#: A rule's token: corners alone order the confirmed maps where they leave no clear winner
#: (the rule before 2026-11-30's "No clear winner by corners: the scans decide").
CORNERS_TIES = "ties=corners"
#: A rule's token: each program's support recomputed from the evidence's pairs with one
#: witness a program (docs/validity.md, "One witness a program")
ONE_WITNESS = "witness=program"
#: A rule's token: where corners cannot compare the confirmed maps, their own scans order
#: them (docs/validity.md, "Maps corners cannot compare: the scans order them"), "on" or
#: "off"
UNCOMPARABLE_ON, UNCOMPARABLE_OFF = "uncomparable=scans", "uncomparable=support"
#: A rule's tokens: the travel veto reads the shortfall along the corridors beyond the
#: shortfall elsewhere (T2), both it and the whole path's (T2-and, shipped since
#: 2026-11-30), or the whole path's alone (the rule before) (docs/validity.md, "Paths
#: shortened along the corridors, not everywhere"; ``slamq.verdict.rule.CORRIDOR_TRAVEL``)
CORRIDOR_TRAVEL, CORRIDOR_AND_WHOLE, WHOLE_PATH = "travel=corridors", "travel=both", \
    "travel=whole"
#: A rule's tokens: a split share confirms a path only where its halves meet (O1, shipped
#: since 2026-12-01), or wherever it is at most the floor (the rule before)
#: (docs/validity.md, "A split share confirms a path only where its halves meet";
#: ``slamq.verdict.rule.SPLIT_MEET``)
SPLIT_MEET, SPLIT_ANYWHERE = "meet=split", "meet=none"
#: A rule's tokens: where the maps disagree (or every map is flagged or partial), the path
#: whose halves cross the least where they meet names its program (P1, the travel veto
#: after it; P1b, not for that pick; P1c, not for any pick the
#: halves set apart), or not (the rule before) (docs/validity.md, "The halves' precision
#: where the maps disagree", "P1c: measured, adopted"; ``slamq.verdict.rule.
#: SPLIT_PRECISION`` and ``SPLIT_PRECISION_TRAVEL``)
HALVES_OFF, HALVES, HALVES_ALONE, HALVES_ANY = ("halves=none", "halves=precision",
                                                "halves=alone", "halves=any")
#: A rule's token: P1c, and the pick may carry the flags of a place drawn twice (P1d,
#: shipped since 2026-12-02; docs/validity.md, "P1d: measured on eight generated sets";
#: ``slamq.verdict.rule.SPLIT_PRECISION_FLAGS``)
HALVES_FLAGS = "halves=flags"
TWICE = ("doubled_walls", "superposed")
#: Each token's (SPLIT_PRECISION, SPLIT_PRECISION_TRAVEL, SPLIT_PRECISION_FLAGS)
_HALVES_RULES = {HALVES_OFF: (False, None, ()), HALVES: (True, None, ()),
                 HALVES_ALONE: (True, "halves", ()), HALVES_ANY: (True, "any", ()),
                 HALVES_FLAGS: (True, "any", TWICE)}
#: A rule's tokens: of two placed maps, a ``doubled_walls`` flag alone on one names the
#: other (the rule before), or only with the other's own scans confirming it (candidate D1,
#: docs/validity.md, "Doubled walls alone do not decide two maps";
#: ``slamq.verdict.rule.MILD_DEFECTS_DECIDE``)
MILD_DECIDES, MILD_NEEDS_SCANS = "mild=decides", "mild=scans"
#: A rule's token: the verdict without the scans (as rule None), with the rule's other
#: tokens applied
NO_SCANS = "scans=none"
#: A rule's tokens: a ``superposed`` flag another program's map shares (the same second
#: wall direction) is lifted (candidate S1), or every flag held as found (the rule before)
#: (docs/validity.md, "A second generator the rule was not tuned on: wing worlds";
#: ``slamq.verdict.rule.SHARED_DIRECTION``); ``"dirdeg=N"`` sets its margin, degrees
#: where both maps have their scans (``SHARED_DIRECTION_DEG``; "A 5-degree margin for S1"),
#: ``"dirdeg0=N"`` where not (``SHARED_DIRECTION_DEG_NO_SCANS``); ``"dir=agree"`` lifts it only
#: when the sharing map agrees with the flagged one (S1a, ``SHARED_DIRECTION_AGREE``; "S1a:
#: a second direction lifted only by a map that agrees")
DIR_SHARED, DIR_OWN, DIR_AGREE = "dir=shared", "dir=own", "dir=agree"

_SEPARATION = re.compile(r"second wall direction ([-\d.]+) deg beside ([-\d.]+) deg "
                         r"\(mod (\d+)\)")


def with_separations(ev: dict[str, Any]) -> dict[str, Any]:
    """``ev`` with each ``superposed`` flag's ``separation`` (degrees between its two wall
    directions, folded to at most half the period) read from its note, where evidence
    cached before the field lacks it.

    Examples
    --------
    >>> note = "second wall direction 59.2 deg beside 0.2 deg (mod 90): 0.99 of the main"
    >>> ev = {"algorithms": {"a": {"defects": {"m": [{"kind": "superposed", "note": note}]}}}}
    >>> with_separations(ev)["algorithms"]["a"]["defects"]["m"][0]["separation"]
    31.0
    """
    from slamq.metrics.defects import direction_separation

    def fill(d: dict[str, Any]) -> dict[str, Any]:
        if d.get("kind") != "superposed" or "separation" in d:
            return d
        m = _SEPARATION.search(d.get("note", ""))
        if m is None:
            return d
        return {**d, "separation": direction_separation(float(m[2]), float(m[1]),
                                                        float(m[3]))}

    algs = {a: {**e, "defects": {p: [fill(d) for d in ds]
                                 for p, ds in e.get("defects", {}).items()}}
            for a, e in ev["algorithms"].items()}
    return {**ev, "algorithms": algs}


def with_split_hits(ev: dict[str, Any]) -> dict[str, Any]:
    """``ev`` with each program's ``split_hit`` (the median of its runs' split hit shares,
    :func:`slamq.verdict.evidence.split_hit`) from its ``splits``, where evidence cached
    before the field lacks it.

    Examples
    --------
    >>> ev = {"splits": {"a1": {"hit_1": 0.1, "hit_2": 0.3}, "a2": {"hit_1": 0.3,
    ...       "hit_2": 0.5}}, "algorithms": {"a": {"defects": {"a1": [], "a2": []}}}}
    >>> round(with_split_hits(ev)["algorithms"]["a"]["split_hit"], 3)
    0.3
    """
    from slamq.verdict.evidence import split_hit

    splits = ev.get("splits", {})
    algs = {a: e if "split_hit" in e else {**e, "split_hit": _median_of(
        [split_hit(splits[p]) for p in e.get("defects", {}) if p in splits])}
        for a, e in ev["algorithms"].items()}
    return {**ev, "algorithms": algs}


def one_witness(ev: dict[str, Any]) -> dict[str, Any]:
    """``ev`` with each placed program's ``support`` recomputed from its ``consistency``
    pairs with one witness a program (:func:`slamq.verdict.evidence.program_support`);
    the rest as it is (with fewer than three programs, all of it).

    Examples
    --------
    >>> c = {"a1": {"a2": 1.0, "b": 0.5, "c": 0.6}, "a2": {"a1": 1.0, "b": 0.5, "c": 0.6},
    ...      "b": {"a1": 0.5, "a2": 0.5, "c": 0.9}, "c": {"a1": 0.6, "a2": 0.6, "b": 0.9}}
    >>> ev = {"consistency": c, "algorithms": {
    ...     "a": {"support": 0.8, "placed": True, "defects": {"a1": [], "a2": []}},
    ...     "b": {"support": 0.5, "placed": True, "defects": {"b": []}},
    ...     "c": {"support": 0.6, "placed": True, "defects": {"c": []}}}}
    >>> round(one_witness(ev)["algorithms"]["a"]["support"], 2)
    0.55
    """
    from slamq.metrics.agreement import finite_median
    from slamq.verdict.evidence import program_support

    owner = {p: a for a, e in ev["algorithms"].items() for p in e.get("defects", {})}
    sup = program_support({p: {o: v for o, v in row.items() if o in owner}
                           for p, row in ev.get("consistency", {}).items() if p in owner},
                          owner)
    if sup is None:
        return ev
    algs = {}
    for a, e in ev["algorithms"].items():
        mine = [sup[p] for p in e.get("defects", {}) if p in sup]
        algs[a] = {**e, "support": finite_median(mine)} if e.get("placed") and mine else e
    return {**ev, "algorithms": algs}


def _judge(summary: pd.DataFrame, seq: str, ev: dict[str, Any], truth: pd.Series,
           broken: pd.Series, rule: tuple | None) -> dict[str, Any]:
    """One verdict (``rule`` = (floor, share[, margin][, ORDER]), None: the evidence
    without scans) and how its choice ranks by the truth."""
    from slamq.verdict import rule as r
    from slamq.verdict.rule import SCAN_KEY, sequence_verdict

    saved = (r.SCAN_FLOOR, r.SCAN_SHARE, r.scan_limit, r._corner_key, r.SHORTFALL,
             r.LOCAL_RATIO, r.LOCAL_ANCHOR, r.SCANS_BREAK_TIES, r.SCANS_ORDER_UNCOMPARABLE,
             r.CORRIDOR_TRAVEL, r.SPLIT_MEET, r.MILD_DEFECTS_DECIDE, r.SHARED_DIRECTION,
             r.SHARED_DIRECTION_DEG, r.SHARED_DIRECTION_AGREE, r.SHARED_DIRECTION_DEG_NO_SCANS,
             r.SPLIT_PRECISION, r.SPLIT_PRECISION_TRAVEL, r.SPLIT_PRECISION_FLAGS)
    try:
        if rule is not None and ONE_WITNESS in rule:
            ev = one_witness(ev)
        if rule is not None:
            ev = with_split_hits(ev)  # evidence cached before the split hit share lacks it
            for x in set(rule) & set(_HALVES_RULES):
                (r.SPLIT_PRECISION, r.SPLIT_PRECISION_TRAVEL,
                 r.SPLIT_PRECISION_FLAGS) = _HALVES_RULES[x]
            if SPLIT_MEET in rule or SPLIT_ANYWHERE in rule:
                r.SPLIT_MEET = SPLIT_MEET in rule
            if MILD_DECIDES in rule or MILD_NEEDS_SCANS in rule:
                r.MILD_DEFECTS_DECIDE = MILD_DECIDES in rule
            if DIR_SHARED in rule or DIR_OWN in rule or DIR_AGREE in rule:
                r.SHARED_DIRECTION = DIR_OWN not in rule
                r.SHARED_DIRECTION_AGREE = DIR_AGREE in rule
                ev = with_separations(ev)
            for x in rule:
                if x == CORNERS_TIES:  # docs/validity.md, "No clear winner by corners"
                    r.SCANS_BREAK_TIES = False
                if x in (UNCOMPARABLE_ON, UNCOMPARABLE_OFF):
                    r.SCANS_ORDER_UNCOMPARABLE = x == UNCOMPARABLE_ON
                if x in (CORRIDOR_TRAVEL, CORRIDOR_AND_WHOLE, WHOLE_PATH):
                    r.CORRIDOR_TRAVEL = None if x == WHOLE_PATH else x.removeprefix("travel=")
                if isinstance(x, str) and x.startswith("dirdeg="):
                    # docs/validity.md, "A 5-degree margin for S1"
                    r.SHARED_DIRECTION_DEG = float(x.removeprefix("dirdeg="))
                if isinstance(x, str) and x.startswith("dirdeg0="):
                    # without both maps' scans ("S1a-5 only where both maps have their scans")
                    r.SHARED_DIRECTION_DEG_NO_SCANS = float(x.removeprefix("dirdeg0="))
                if isinstance(x, str) and x.startswith("shortfall="):
                    r.SHORTFALL = float(x.removeprefix("shortfall="))
                if isinstance(x, str) and x.startswith("local="):
                    # docs/validity.md, "A fifth real log ...": none (SCAN_FLOOR alone),
                    # path (C3) or lowest (C3')
                    anchor = x.removeprefix("local=")
                    r.LOCAL_RATIO = None if anchor == "none" else r.SCAN_SHARE
                    r.LOCAL_ANCHOR = anchor if anchor != "none" else r.LOCAL_ANCHOR
            nums = [x for x in rule if not isinstance(x, str)]
            r.SCAN_FLOOR, r.SCAN_SHARE = nums[0], nums[1]
            if len(nums) > 2 or MEDIAN in rule:
                r.scan_limit = _limit_with_margin(*nums, median=MEDIAN in rule)
            if ORDER in rule:
                scans = {a: float(e.get(SCAN_KEY, math.nan))
                         for a, e in ev["algorithms"].items()}
                r._corner_key = _scan_order(saved[3], scans)
        v = sequence_verdict(summary, seq, ev if rule is not None and NO_SCANS not in rule
                             else _without_scans(ev))
    finally:
        (r.SCAN_FLOOR, r.SCAN_SHARE, r.scan_limit, r._corner_key, r.SHORTFALL,
         r.LOCAL_RATIO, r.LOCAL_ANCHOR, r.SCANS_BREAK_TIES, r.SCANS_ORDER_UNCOMPARABLE,
         r.CORRIDOR_TRAVEL, r.SPLIT_MEET, r.MILD_DEFECTS_DECIDE, r.SHARED_DIRECTION,
         r.SHARED_DIRECTION_DEG, r.SHARED_DIRECTION_AGREE, r.SHARED_DIRECTION_DEG_NO_SCANS,
         r.SPLIT_PRECISION, r.SPLIT_PRECISION_TRAVEL, r.SPLIT_PRECISION_FLAGS) = saved
    best = v["best"]
    return {"best": best, "rank": float(truth.rank()[best]) if best in truth.index
            else math.nan,
            "ratio": float(truth[best] / truth.min()) if best in truth.index else math.nan,
            "broken_named": bool(broken.get(best, False)) if best else False,
            "reason": v["confidence"]}


def weigh(ev: dict[str, Any], block: pd.DataFrame, figure: str,
          values: dict[str, float] | None = None) -> dict[str, Any]:
    """The evidence with the field the verdict's scan rule reads
    (:data:`slamq.verdict.rule.SCAN_KEY`) set, for each program, to the median of its maps'
    ``figure`` (``crossing_share`` or ``violation_share``): the verdict then weighs that
    figure in the veto and the confirmation, nothing else changed. ``values`` (map path ->
    figure) replaces the evidence's figures of the maps scored against their scans
    (``split_crossing``: studies/split_scans.py). ``c2``: the crossing share as the
    verdict reads it, and the split share of ``values`` beside it (``scan_split``, which
    the rule weighs since docs/validity.md's candidate C2 became it).

    Examples
    --------
    >>> ev = {"algorithms": {"a": {"scan_crossing": 0.05}},
    ...       "scans": {"m1": {"violation_share": 0.3, "crossing_share": 0.05}}}
    >>> block = pd.DataFrame({"map": ["m1"], "algorithm": ["a"]})
    >>> weigh(ev, block, "violation_share")["algorithms"]["a"]["scan_crossing"]
    0.3
    """
    from slamq.verdict.rule import SCAN_KEY

    if figure == "c2":  # the maps' crossing share and the split one beside it
        out = weigh(ev, block, "crossing_share")
        split = weigh(ev, block, "split_crossing", values)
        for alg, e in out["algorithms"].items():
            e["scan_split"] = split["algorithms"][alg][SCAN_KEY]
        return out
    out = dict(ev)
    out["algorithms"] = {}
    for alg, e in ev["algorithms"].items():
        vals = [ev["scans"][str(m)][figure] if values is None
                else values.get(str(m), math.nan) for m in block.loc[
                block["algorithm"].astype(str) == alg, "map"]
                if str(m) in ev.get("scans", {})]
        vals = [v for v in vals if isinstance(v, float) and math.isfinite(v)]
        out["algorithms"][alg] = {**e, SCAN_KEY: float(np.median(vals)) if vals
                                  else math.nan}
    return out


_DIRECTIONS: dict[str, Any] = {}


def _directions(block: pd.DataFrame) -> dict[str, Any]:
    """The recordings of ``block``'s rows, each with its scored scans
    (:func:`slamq.metrics.degeneracy.scan_degeneracy`, measured once per process)."""
    from slamq.metrics.degeneracy import scan_degeneracy
    from slamq.verdict.scans import recording

    paths = {str(p) for p in block["scans"].dropna()}
    for path in paths - set(_DIRECTIONS):
        _DIRECTIONS[path] = scan_degeneracy(recording(path))
    return {p: _DIRECTIONS[p] for p in paths}


def _degenerate_share(block: pd.DataFrame) -> float:
    """The highest degenerate share (docs/spec.md 7c) of the recordings of ``block``'s rows,
    as :func:`slamq.verdict.evidence.sequence_evidence` gives it."""
    from slamq.verdict.evidence import _highest

    return _highest([d.share for d in _directions(block).values()])


def _fill_shortfalls(ev: dict[str, Any], block: pd.DataFrame) -> None:
    """Each program's ``shortfall`` and ``corridor_shortfall`` (docs/spec.md 7d) set in
    ``ev`` from ``block``'s trajectories, as :func:`slamq.verdict.evidence.
    sequence_evidence` sets them."""
    from slamq.verdict.travel import path_shortfalls

    short, along = path_shortfalls(block.to_dict("records"), directions=_directions(block)
                                   if "scans" in block else None)
    for alg, e in ev["algorithms"].items():
        e["shortfall"], e["shortfall_against"] = short.get(alg, (math.nan, None))
        e["corridor_shortfall"], e["corridor_shortfall_against"] = along.get(
            alg, (math.nan, None))


def refresh_defects(cache: dict) -> int:
    """Every cached evidence's defect flags again, with today's detectors (each map read
    once): ``defects`` and ``flagged_runs`` of each program; the rest of the evidence does
    not depend on them. Returns how many maps were read.

    Examples
    --------
    >>> refresh_defects({("s", ()): {"algorithms": {"a": {"defects": {}, "flagged_runs": 0}}}})
    0
    """
    from slamq.metrics.defects import detect_defects
    from slamq.sources import load_map

    memo: dict[str, list[dict[str, Any]]] = {}
    for ev in cache.values():
        for e in ev["algorithms"].values():
            for path in e.get("defects", {}):
                if path not in memo:
                    memo[path] = [d.to_dict() for d in detect_defects(load_map(path))]
            e["defects"] = {p: memo[p] for p in e.get("defects", {})}
            e["flagged_runs"] = sum(1 for found in e["defects"].values() if found)
    return len(memo)


def verdicts(df: pd.DataFrame, truth: str, *, rules: tuple = (None,), pair: bool = False,
             cache: dict | None = None, figure: str = "violation_share",
             by_run: bool = False, values: dict[str, float] | None = None,
             local: dict[str, float] | None = None) -> pd.DataFrame:
    """The verdict of each sequence (or, with ``pair``, each pair of programs of each
    sequence) with the truth hidden, for each rule of ``rules`` ((floor, share) of the
    scan veto; None: without the scans), the scans weighed by ``figure``
    (:func:`weigh`); ``cache`` keeps each case's evidence (the costly part) between
    calls; ``by_run``: one case per sequence and run (iteration) instead of per
    sequence; ``values``: as :func:`weigh`'s; ``local``: each map's path's local share
    (``local-rows.csv``), each program's median set as the evidence's ``scan_local``."""
    from slamq.verdict.evidence import sequence_evidence
    from slamq.verdict.ranking import summarize
    from slamq.verdict.rule import SCAN_KEY

    ok = df[df["map"].notna()].copy()
    hidden = _hidden(ok)
    if pair:
        cases = pairs(ok)
    elif by_run:
        cases = [(f"{s}#{r}", b) for (s, r), b in ok.groupby(["sequence", "run"])]
    else:
        cases = [(str(s), b) for s, b in ok.groupby("sequence")]
    rows = []
    for label, block in cases:
        seq = str(block["sequence"].iloc[0])
        sub = hidden.loc[block.index]
        key = (label, tuple(sorted(sub["map"])))
        if cache is not None and key in cache:
            ev = cache[key]
        else:
            ev = sequence_evidence(sub, seq)
            if cache is not None:
                cache[key] = ev
        if "degenerate_share" not in ev:  # evidence cached before docs/spec.md 7c
            ev["degenerate_share"] = _degenerate_share(block)
        if cache is not None:  # cheap: measured again, as the figure is now
            _fill_shortfalls(ev, block)
        ev = weigh(ev, block, figure, values)
        if local is not None:
            ev = {**ev, "algorithms": {a: {**e, "scan_local": _median_of(
                [local.get(str(m), math.nan) for m in block.loc[
                    block["algorithm"].astype(str) == a, "map"]])}
                for a, e in ev["algorithms"].items()}}
        summary = summarize(sub)
        t = block.groupby("algorithm")[truth].mean()
        best = t.min()
        broken = (t > 3 * best) & (t > 0.2)
        row: dict[str, Any] = {"case": label, "sequence": seq,
                               "algorithms": ", ".join(sorted(t.index)),
                               "truth_best": str(t.idxmin()),
                               "scans": {a: e.get(SCAN_KEY)
                                         for a, e in ev["algorithms"].items()},
                               "majority": ev["majority"], "group": ev.get("group")}
        for rule in rules:
            name = rule_name(rule)
            for k, v in _judge(summary, seq, ev, t, broken, rule).items():
                row[f"{k}@{name}"] = v
        rows.append(row)
    return pd.DataFrame(rows)


def _median_of(values: list[float]) -> float:
    finite = [v for v in values if math.isfinite(v)]
    return float(np.median(finite)) if finite else math.nan


def verdict_table(v: pd.DataFrame, rules: tuple, *, pair: bool = False) -> str:
    """Per rule: cases, named, named in the truth's top two (top one for pairs), broken
    named, abstained."""
    out = ["| rule | cases | named | " + ("named the better of the two" if pair else
                                        "named in the truth's top two")
           + " | named a run > 3x the best (broken) | abstained |", "|---|---|---|---|---|---|"]
    for rule in rules:
        name = rule_name(rule)
        best = v[f"best@{name}"]
        named = best.notna()
        good = (v[f"rank@{name}"] <= (1 if pair else 2)) & named
        margin = rule[2] if rule is not None and len(rule) > 2 else None
        label = ("without scans" if rule is None else f"floor {rule[0]:g}, share {rule[1]:g}"
                 + (f", margin {margin:g}" if isinstance(margin, float) else "")
                 + (", scans order" if ORDER in rule else "")
                 + (", anchored on the median" if MEDIAN in rule else "")
                 + "".join(f", travel veto {x.removeprefix('shortfall=')}" for x in rule
                           if isinstance(x, str) and x.startswith("shortfall="))
                 + "".join(f", local floor {x.removeprefix('local=')}" for x in rule
                           if isinstance(x, str) and x.startswith("local="))
                 + (", split confirms without its halves meeting" if SPLIT_ANYWHERE in rule
                    else "")
                 + (", a second direction another program draws lifted" if DIR_SHARED in rule
                    else "")
                 + (", a second direction an agreeing program draws lifted"
                    if DIR_AGREE in rule else "")
                 + (", without the halves' precision (the rule before 2026-12-02)"
                    if HALVES_OFF in rule else "")
                 + (", the halves' precision where the maps disagree (P1)" if HALVES in rule
                    else "")
                 + (", the halves' precision, no travel veto after it (P1b)"
                    if HALVES_ALONE in rule else "")
                 + (", the halves' precision, no travel veto where they separate the paths "
                    "(P1c)" if HALVES_ANY in rule else "")
                 + (", P1c with the flags of a place drawn twice set aside (P1d)"
                    if HALVES_FLAGS in rule else ""))
        out.append(f"| {label} | {len(v)} | {int(named.sum())} | {int(good.sum())} of "
                   f"{len(v)} ({100 * good.mean():.0f}%) | {int(v[f'broken_named@{name}'].sum())}"
                   f" | {int((~named).sum())} |")
    return "\n".join(out) + "\n"


def split_values(df: pd.DataFrame, output: Path, name: str = "split-rows.csv"
                 ) -> dict[str, float]:
    """Each map of ``df`` (by its ``map`` value) with its split crossing share from
    ``OUTPUT/split-rows.csv`` (studies/split_scans.py; ``name``: a variant's rows), matched
    by algorithm, sequence and run; NaN where it has none."""
    split = pd.read_csv(output / name)
    key = {(str(r.algorithm), str(r.sequence), str(r.run)): float(r.split_crossing)
           for r in split.itertuples()}
    return {str(m): key.get((str(a), str(s), str(r)), math.nan)
            for m, a, s, r in zip(df["map"], df["algorithm"], df["sequence"], df["run"])}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    ap.add_argument("kind", choices=("benchmark", "real"))
    ap.add_argument("output", type=Path, nargs="+",
                    help="real: several outputs are one set of runs (e.g. examples/"
                    "real2d-runs and studies/real2d-gmapping-runs); the files are written "
                    "into the last")
    ap.add_argument("--grid", action="store_true",
                    help="the verdicts for every (floor, share) of the veto's grid (set A)")
    ap.add_argument("--no-verdict", action="store_true", help="the figures only")
    ap.add_argument("--refresh-defects", action="store_true",
                    help="with --cached: every map's defect flags again with today's "
                    "detectors (the rest of the cached evidence does not depend on them)")
    ap.add_argument("--cached", action="store_true",
                    help="reuse the evidence of an earlier call (OUTPUT/scans-evidence.pkl): "
                    "only the rule is applied again")
    ap.add_argument("--max-scans", type=int, default=None,
                    help="with --cached: the scans' figures again with at most N scans a map")
    ap.add_argument("--figure", choices=("violation_share", "crossing_share",
                                         "split_crossing", "c2"),
                    default="crossing_share",
                    help="the scan figure the verdict weighs (docs/validity.md, 'Walls "
                    "crossed, not grazed'; split_crossing: OUTPUT/split-rows.csv of "
                    "studies/split_scans.py, 'A trajectory against its own scans, split "
                    "in time')")
    ap.add_argument("--split-rows", default="split-rows.csv",
                    help="with --figure split_crossing or c2: the rows file of "
                    "studies/split_scans.py in OUTPUT (a variant's, --rows there)")
    ap.add_argument("--locals", action="store_true",
                    help="the rule with the confirmation floor of SCAN_FLOOR alone, C3 and "
                    "C3' (docs/validity.md, 'A fifth real log ...'), each path's local "
                    "share read from OUTPUT/local-rows.csv (studies/split_scans.py --local)")
    ap.add_argument("--rule", type=float, nargs=2, metavar=("V", "K"), default=None,
                    help="the veto's floor and share (default: slamq's)")
    ap.add_argument("--margins", action="store_true",
                    help="also the rule with each margin of MARGINS (the veto's third term)")
    ap.add_argument("--shortfalls", action="store_true",
                    help="the rule with each travel veto of SHORTFALLS (inf: none)")
    ap.add_argument("--median", action="store_true",
                    help="also the veto anchored on the median, for each of MEDIAN_SHARES")
    ap.add_argument("--by-run", action="store_true",
                    help="one verdict per sequence and iteration (the real logs' 3 runs)")
    ap.add_argument("--rows", action="store_true",
                    help="reuse the scored rows of an earlier call (OUTPUT/scans-rows.csv)")
    ap.add_argument("--ties", action="store_true",
                    help="also the rule with corners alone where they leave no clear winner "
                    "(docs/validity.md, 'No clear winner by corners: the scans decide')")
    ap.add_argument("--one-witness", action="store_true",
                    help="also each program's support with one witness a program "
                    "(docs/validity.md, 'One witness a program')")
    ap.add_argument("--uncomparable", action="store_true",
                    help="also the rule with the maps corners cannot compare ordered by "
                    "their own scans, and with their support (docs/validity.md, 'Maps "
                    "corners cannot compare: the scans order them')")
    ap.add_argument("--whole-path", action="store_true",
                    help="also the travel veto on the whole path alone, the rule before "
                    "2026-11-30 (docs/validity.md, 'Paths shortened along the corridors: "
                    "measured, T2-and adopted')")
    ap.add_argument("--split-meet", action="store_true",
                    help="also the rule with a split share confirming a path wherever it is "
                    "at most the floor, the rule before 2026-12-01 (docs/validity.md, 'A "
                    "split share confirms a path only where its halves meet')")
    ap.add_argument("--shared-direction", action="store_true",
                    help="also the rule with a superposed flag lifted where another "
                    "program's map draws the same second direction (docs/validity.md, 'A "
                    "second generator the rule was not tuned on: wing worlds')")
    ap.add_argument("--shared-agree", action="store_true",
                    help="also the rule with it lifted only where that map agrees with the "
                    "flagged one (docs/validity.md, 'S1a: a second direction lifted only "
                    "by a map that agrees')")
    ap.add_argument("--halves", action="store_true",
                    help="also the rule without the halves' precision (the rule before "
                    "2026-12-02), with it as P1 and as P1b (docs/validity.md, 'The halves' "
                    "precision where the maps disagree'), and P1d ('The halves against the flags "
                    "of a place drawn twice'); the rule as shipped is P1d")
    ap.add_argument("--no-pairs", action="store_true",
                    help="the sequences (or runs) only, not every pair of programs")
    a = ap.parse_args(argv if argv is not None else sys.argv[1:])
    outputs = a.output
    if len(outputs) > 1 and a.kind == "benchmark":
        raise SystemExit("benchmark: one output")
    a.output = outputs[-1]
    if a.rows and a.kind == "benchmark":
        df = pd.read_csv(a.output / "scans-rows.csv")
        truth, label = "ate_rmse", "the ATE RMSE"
    elif a.rows:
        df = pd.read_csv(a.output / "scans-rows.csv")
        truth, label = "rel_trans_abs_mean", "the mean abs translational relations error"
    elif a.kind == "benchmark":
        df = score_runs(benchmark_rows(a.output))
        truth, label = "ate_rmse", "the ATE RMSE"
    else:  # real
        df = score_runs(with_broken(pd.concat([real_rows(o) for o in outputs],
                                              ignore_index=True)))
        truth, label = "rel_trans_abs_mean", "the mean abs translational relations error"
    df.to_csv(a.output / "scans-rows.csv", index=False)
    sys.stdout.write(tables(df, truth, label))
    if a.no_verdict:
        return 0
    from slamq.verdict import rule as r

    rules = (None, *GRID) if a.grid else (None, tuple(a.rule) if a.rule else
                                          (r.SCAN_FLOOR, r.SCAN_SHARE))
    if a.margins:  # F1 and F2 of docs/validity.md, "A veto with a margin"
        vk = rules[-1][:2]
        rules = (*rules, *((*vk, g) for g in MARGINS),
                 *((*vk, g, ORDER) for g in MARGINS))
    if a.shortfalls:  # docs/validity.md, "Paths shortened along a corridor"
        vk = rules[-1][:2]
        rules = (None, *((*vk, f"shortfall={t:g}") for t in SHORTFALLS))
    if a.ties:
        rules = (*rules, (*rules[-1][:2], CORNERS_TIES))
    if a.one_witness:
        rules = (*rules, (*rules[-1][:2], ONE_WITNESS))
    if a.uncomparable:
        vk = rules[-1][:2]
        rules = (*rules, (*vk, UNCOMPARABLE_OFF), (*vk, UNCOMPARABLE_ON))
    if a.whole_path:
        rules = (*rules, (*rules[-1][:2], WHOLE_PATH))
    if a.split_meet:
        rules = (*rules, (*rules[-1][:2], SPLIT_ANYWHERE))
    if a.shared_direction:
        rules = (*rules, (*rules[-1][:2], DIR_SHARED))
    if a.shared_agree:
        rules = (*rules, (*rules[-1][:2], DIR_AGREE))
    if a.halves:
        vk = rules[-1][:2]
        rules = (*rules, *((*vk, x) for x in (HALVES_OFF, HALVES, HALVES_ALONE,
                                              HALVES_FLAGS)))
    if a.locals:
        vk = rules[-1][:2]
        rules = (None, *((*vk, f"local={x}") for x in ("none", "path", "lowest")))
    if a.median:  # F3 of docs/validity.md, "A veto anchored on the middle map"
        rules = (*rules, *((rules[1][0], k, MEDIAN) for k in MEDIAN_SHARES))
    import pickle

    store = a.output / "scans-evidence.pkl"
    cache = pickle.loads(store.read_bytes()) if store.exists() and a.cached else {}
    if a.max_scans is not None:
        # the scans' part of the cached evidence again, at most N scans a map: the rest of
        # the evidence (agreement, defects) does not depend on it
        from slamq.sources import load_map
        from slamq.verdict.scans import record_consistency

        recs = {str(r["map"]): r for r in df.to_dict("records")}
        figures = {m: record_consistency(r, load_map(m), max_scans=a.max_scans).to_dict()
                   for m, r in recs.items()}
        for ev in cache.values():
            # each program's scan figure is taken from these by weigh() in verdicts()
            ev["scans"] = {m: figures[m] for m in ev.get("scans", {})}
        if not a.cached:
            raise SystemExit("--max-scans needs --cached")
        store = a.output / f"scans-evidence-{a.max_scans}.pkl"
    if a.refresh_defects:
        if not a.cached:
            raise SystemExit("--refresh-defects needs --cached")
        refresh_defects(cache)
    values = (split_values(df, a.output, a.split_rows)
              if a.figure in ("split_crossing", "c2") else None)
    local = None
    if a.locals:
        rows = pd.read_csv(a.output / "local-rows.csv")
        local = dict(zip(rows["map"].astype(str), rows["local_crossing"].astype(float)))
    for pair in (False,) if a.no_pairs else (False, True):
        v = verdicts(df, truth, rules=rules, pair=pair, cache=cache, figure=a.figure,
                     by_run=a.by_run, values=values, local=local)
        store.write_bytes(pickle.dumps(cache))
        suffix = ("-locals" if a.locals else "") + (f"-{a.max_scans}" if a.max_scans else "") + (
            "" if a.figure == "violation_share" else f"-{a.figure}") + (
            "" if a.split_rows == "split-rows.csv" or a.figure not in (
                "split_crossing", "c2") else f"-{Path(a.split_rows).stem}")
        v.to_csv(a.output / f"scans-verdicts{'-pairs' if pair else ''}{suffix}.csv",
                 index=False)
        sys.stdout.write(("\nTwo-map cases (every pair of programs of a sequence):\n\n"
                          if pair else "\nThe verdict, the truth hidden:\n\n")
                         + verdict_table(v, rules, pair=pair))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
