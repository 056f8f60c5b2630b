"""How far the no-ground-truth verdict can be trusted: measured on the ground-truth
benchmark with the ground truth hidden, and on real folders ranked by eye
(docs/validity.md, "The verdict without ground truth").

``python studies/verdict_study.py --benchmark OUTPUT --real MAPS studies/by_eye.csv
--markdown docs/validity.md`` regenerates the tables.

- :func:`benchmark_verdicts`: every sequence of a ``slamq run`` output with generated
  ground truth (:mod:`slamq.synth.benchmark`; studies/benchmark_study.py): the verdict
  computed from the maps alone (every ``ate_*`` and ``gt_*`` column dropped) against the
  trajectory error.
- :func:`folder_verdicts`: folders of real maps of one place: the verdict against the
  by-eye classes of a CSV (``folder, map, class, broken``; class 1 best; studies/by_eye.csv).
- :func:`first_rule`: the first rule of 2026-11-25, retired, frozen here to measure the
  shipped rule against (the package holds the shipped rule only).
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from _common import print_or_write_section

from slamq.params import SETTINGS
from slamq.results.columns import GROUND_TRUTH_ALGORITHMS
from slamq.results.summary import ANGLE_TOLERANCE_DEG, angle_spread, distinct_resolutions
from slamq.verdict.evidence import sequence_evidence
from slamq.verdict.ranking import summarize
from slamq.verdict.rule import AGREEMENT_SHARE, COMPLETE_SHARE, sequence_verdict

__all__ = ["benchmark_verdicts", "by_eye_agreement", "first_rule", "folder_verdicts",
           "markdown", "main"]

BEGIN, END = "<!-- verdict-study:begin -->", "<!-- verdict-study:end -->"
#: The benchmark's sets, by simulation seed (docs/validity.md says why seeds 1-2 became
#: tuning data): label, seeds.
BENCHMARK_SETS = (("tuning: seed 0", ("s0",)),
                  ("tuning: seeds 1-2 (seen with the first rule)", ("s1", "s2")),
                  ("held out: 18 new worlds, seed 3", ("s3",)),
                  ("held out 2 (for the rule of 2026-11-27): 18 more worlds, seed 4",
                   ("s4",)),
                  ("held out 3 (after that rule shipped): 18 more worlds, seed 5", ("s5",)))

#: The set of a generator the rules were not tuned on (issue 41): label, world kind in the
#: sequence name (studies/benchmark-holdout-hex.yaml).
OTHER_GENERATOR = ("held out, a generator not tuned on: 8 hexagonal worlds, seed 5",
                   "hexagonal")


#: The grid (m) the first and the old rule's ``corners_canonical`` is computed at (off by
#: default since 2026-11-27): the benchmark sets and the real folders alike.
CANONICAL_RESOLUTION = 0.07


def _hidden(df: pd.DataFrame) -> pd.DataFrame:
    """The rows with every ground-truth column dropped."""
    return df.drop(columns=[c for c in df.columns
                            if c.startswith(("ate_", "gt_", "groundtruth"))])


def with_scans(df: pd.DataFrame, output: Path) -> pd.DataFrame:
    """``df`` with ``scans`` filled where a record has none and its sequence's recording is
    in the run folder (``sequences/NAME/NAME.rawlog``, which ``slamq run`` records as
    ``scans`` since 2026-11-28; sets run before then have no such column).

    Examples
    --------
    >>> import tempfile
    >>> d = Path(tempfile.mkdtemp()); (d / "sequences" / "s").mkdir(parents=True)
    >>> _ = (d / "sequences" / "s" / "s.rawlog").write_bytes(b"")
    >>> df = pd.DataFrame({"sequence": ["s", "t"], "scans": [None, None]})
    >>> [Path(p).name if isinstance(p, str) else "-" for p in with_scans(df, d)["scans"]]
    ['s.rawlog', '-']
    """
    out = df.copy()
    if "scans" not in out:
        out["scans"] = None
    out["scans"] = out["scans"].astype(object)
    for i, r in out.iterrows():
        if isinstance(r["scans"], str) and r["scans"]:
            continue
        rawlog = Path(output) / "sequences" / str(r["sequence"]) / f"{r['sequence']}.rawlog"
        out.at[i, "scans"] = str(rawlog) if rawlog.exists() else None
    return out


def benchmark_verdicts(output: Path, *, sequences: Iterable[str] | None = None,
                       align: str = SETTINGS.agreement_align.default,
                       defects: bool = True, fill_scans: bool = False,
                       most_likely: bool = False) -> pd.DataFrame:
    """The verdict of each benchmark sequence with the ground truth hidden.

    Parameters
    ----------
    output : path
        A ``slamq run`` output folder of generated sequences (``examples/benchmark.yaml``).
    sequences : iterable of str, optional
        Only these sequences.
    align : str, default "auto"
        How the maps are put in one frame (:func:`slamq.agreement`).
    defects : bool, default True
        Run the defect detectors (False: agreement alone).
    most_likely : bool, default False
        rbpf-slam read at the path its map is drawn at (``most_likely_path.txt``), its ATE
        too, and ``broken`` measured again with it (docs/validity.md, "rbpf-slam read
        wholly at its most likely path"; :func:`rbpf_path_study.most_likely_paths`).

    Returns
    -------
    pandas.DataFrame
        One row per sequence: ``sequence``, ``best`` (None: abstained), ``ate_rank`` of the
        named algorithm (1 best), ``ate_ratio`` (its ATE over the best), ``broken_named``,
        ``reason``, and the same for the first rule of 2026-11-25 (``first_best``,
        ``first_ate_rank``, ``first_broken_named``) and the old rule (corners alone):
        ``old_best``, ``old_ate_rank``, ``old_broken_named``.
    """
    from benchmark_study import load_benchmark

    df = load_benchmark(Path(output))
    df = df[df["outcome"] == "ok"]
    if most_likely:
        from benchmark_study import mark_broken
        from rbpf_path_study import most_likely_paths

        df = most_likely_paths(df, Path(output))
        df["ate_rmse"] = df.pop("ate_ml")
        df = mark_broken(df)
    if fill_scans:
        df = with_scans(df, Path(output))
    if sequences is not None:
        df = df[df["sequence"].isin(set(sequences))]
    df = _with_wall_symmetry(_with_canonical_corners(df))
    hidden = _hidden(df)
    summary = summarize(hidden)
    rows = []
    for seq, block in df.groupby("sequence", sort=True):
        ev = sequence_evidence(hidden, str(seq), align=align, defects=defects)
        v = sequence_verdict(summary, str(seq), ev)
        ate = block.groupby("algorithm")["ate_rmse"].mean()
        best = v["best"]
        rank = float(ate.rank()[best]) if best in ate.index else math.nan
        ratio = float(ate[best] / ate.min()) if best in ate.index else math.nan
        broken = bool(block.loc[block["algorithm"] == best, "broken"].any()) if best else False
        old = sequence_verdict(summary, str(seq))["best"]  # corners alone: the old rule
        first = first_rule(summary, str(seq), ev)["best"]
        rows.append({"sequence": seq, "best": best, "ate_rank": rank, "ate_ratio": ratio,
                     "broken_named": broken, "reason": v["confidence"],
                     "first_best": first,
                     "first_ate_rank": float(ate.rank()[first]) if first in ate.index
                     else math.nan,
                     "first_broken_named": bool(block.loc[block["algorithm"] == first,
                                                          "broken"].any()) if first else False,
                     "old_best": old,
                     "old_ate_rank": float(ate.rank()[old]) if old in ate.index else math.nan,
                     "old_broken_named": bool(block.loc[block["algorithm"] == old,
                                                        "broken"].any()) if old else False})
    return pd.DataFrame(rows)


def _with_wall_symmetry(df: pd.DataFrame) -> pd.DataFrame:
    """``df`` with ``wall_symmetry`` (docs/spec.md 3a.2) filled in where it is missing, and
    a hexagonal map's ``wall_angle`` taken modulo 60 as the core now gives it: sets scored
    before the classes existed are measured as a scoring today would give them (a
    rectilinear or irregular map's wall angle is the one it has)."""
    from slamq import native
    from slamq.models.quality import wall_symmetry
    from slamq.sources import load_map

    df = df.copy()
    if "wall_symmetry" not in df.columns:
        df["wall_symmetry"] = None
    missing = df["wall_symmetry"].isna() & df["map"].notna()
    for i in df.index[missing]:
        m = load_map(str(df.at[i, "map"]))
        cls, angle = wall_symmetry(native.wall_harmonics(m.values, m.unknown),
                                   math.radians(float(df.at[i, "wall_angle"])))
        df.at[i, "wall_symmetry"] = cls
        if cls == "hexagonal":
            df.at[i, "wall_angle"] = angle
    return df


def _with_canonical_corners(df: pd.DataFrame) -> pd.DataFrame:
    """``df`` with ``corners_canonical`` (at :data:`CANONICAL_RESOLUTION`) filled in where
    it is missing: it is off by default since 2026-11-27, and the first rule and the old
    rule rank by it, so a set scored with the defaults is measured with them as the
    earlier sets were. The second rule does not read it."""
    from slamq.api import evaluate

    df = df.copy()
    if "corners_canonical" not in df.columns:
        df["corners_canonical"] = math.nan
    missing = df["corners_canonical"].isna() & df["map"].notna()
    if not missing.any():
        return df
    df["corners_canonical"] = df["corners_canonical"].astype(float)
    df.loc[missing, "corners_canonical"] = [
        evaluate(str(m), canonical_resolution=CANONICAL_RESOLUTION).corners_canonical
        for m in df.loc[missing, "map"]]
    return df


def folder_verdicts(root: Path, by_eye: Path, *,
                    align: str = SETTINGS.agreement_align.default, defects: bool = True
                    ) -> tuple[pd.DataFrame, dict[str, dict[str, Any]]]:
    """The verdict on each folder of real maps listed in a by-eye CSV.

    Parameters
    ----------
    root : path
        The folder the CSV's ``folder`` column is relative to (the corpus's maps folder,
        :data:`_common.SHARED_MAPS`).
    by_eye : path
        CSV with ``folder, map, class, broken`` (class 1 best; broken 1 or 0).
    align : str, default "auto"
    defects : bool, default True

    Returns
    -------
    (pandas.DataFrame, dict)
        The by-eye table with the scored maps' rows, and the verdict per folder (its
        ``first_rule``: the verdict of the first rule of 2026-11-25 on the same evidence).
    """
    from slamq.api import evaluate

    eye = pd.read_csv(by_eye)
    records = []
    for r in eye.itertuples():
        path = Path(root) / r.folder / r.map
        # the first rule ranks by corners_canonical
        q = evaluate(str(path), canonical_resolution=CANONICAL_RESOLUTION)
        records.append({"map": str(path), "sequence": r.folder, "algorithm": r.map, "run": 1,
                        **q.to_dict()})
    ok = pd.DataFrame(records)
    summary = summarize(ok)
    verdicts = {}
    for folder in eye["folder"].unique():
        ev = sequence_evidence(ok, folder, align=align, defects=defects)
        verdicts[folder] = sequence_verdict(summary, folder, ev)
        verdicts[folder]["first_rule"] = first_rule(summary, folder, ev)
    return eye, verdicts


# --------------------------------------------------------------------------------------
# The first rule (2026-11-25), retired: frozen here so that the study can replay it.


def _finite_means(block: pd.DataFrame, key: str) -> pd.Series:
    col = f"{key}_mean"
    if col not in block:
        return pd.Series(dtype=float)
    values = pd.to_numeric(block[col], errors="coerce")
    return values[np.isfinite(values.to_numpy(dtype=float))]


def _first_rule_corner_key(part: pd.DataFrame) -> tuple[str | None, pd.Series]:
    """The first rule's corner column for the maps the agreement confirms equally:
    ``corners_canonical`` when they differ in resolution or orientation (wall angles more
    than ``ANGLE_TOLERANCE_DEG`` apart modulo 90), else plain ``corners`` (or
    ``corners_canonical`` when some map has no plain count); None when a map has neither.
    (The shipped rule never uses ``corners_canonical`` here: maps of different grids are
    ordered by their support.)"""
    differ = (len(distinct_resolutions(part.get("resolution_mean", []))) > 1
              or angle_spread(part.get("wall_angle_mean", [])) > ANGLE_TOLERANCE_DEG)
    for key in ("corners_canonical",) if differ else ("corners", "corners_canonical"):
        means = _finite_means(part, key)
        if len(means) == len(part):
            return key, means
    return None, pd.Series(dtype=float)


def _confirmed(evidence: dict[str, Any], names: Iterable[str]) -> set[str]:
    """Of the algorithms ``names`` (a sequence's, reference maps left out), those the
    agreement confirms equally: placed, not flagged by the defect detectors on at least
    half of their runs, not vetoed by their own scans (the shipped rule's
    ``_scan_flags``, which the first rule is measured with too), with a support of at least
    ``AGREEMENT_SHARE`` of the best and a completeness of at least ``COMPLETE_SHARE`` of
    the highest (the flags both rules share)."""
    from slamq.verdict.rule import _scan_flags

    names = set(names)
    info = {str(a): e for a, e in evidence["algorithms"].items() if a in names}
    vetoed = set(_scan_flags(info)[1])
    support = {a: e["support"] for a, e in info.items() if math.isfinite(e["support"])}
    complete = {a: e["completeness"] for a, e in info.items()
                if math.isfinite(e["completeness"])}
    top = max(support.values()) if support else math.nan
    most = max(complete.values()) if complete else math.nan

    def ok(a: str) -> bool:
        e = info[a]
        flagged = not e["placed"] or (e["flagged_runs"] and 2 * e["flagged_runs"] >= e["runs"])
        return (not flagged and a not in vetoed and support[a] >= AGREEMENT_SHARE * top
                and not complete.get(a, math.inf) < COMPLETE_SHARE * most)

    return {a for a in support if ok(a)}


def first_rule(summary: pd.DataFrame, sequence: str, evidence: dict[str, Any] | None
               ) -> dict[str, Any]:
    """The verdict of the first rule of 2026-11-25 on the same evidence as the shipped rule.

    The two rules differ in one thing: without ground truth, the first ordered the maps the
    agreement confirms equally by ``corners_canonical`` when they differ in resolution or
    orientation (:func:`_first_rule_corner_key`); the shipped rule orders them by their
    support. Everything else (ground truth first, the flags, partial maps, when to
    abstain) is the shipped rule's, so this re-orders the confirmed maps at the head of
    the shipped verdict's ranking.

    Returns
    -------
    dict
        ``{"sequence", "best", "ranking", "basis"}`` as :func:`sequence_verdict`.

    Examples
    --------
    >>> from slamq.verdict.ranking import summarize
    >>> df = pd.DataFrame({"sequence": "s", "algorithm": list("abc"),
    ...                    "corners": [10, 500, 300], "corners_canonical": [10, 500, 300],
    ...                    "resolution": [0.05, 0.07, 0.05], "wall_angle": 0.0})
    >>> ev = {"majority": True, "notes": [], "algorithms": {
    ...     a: {"support": s, "completeness": 1.0, "placed": True, "runs": 1,
    ...         "flagged_runs": 0, "defects": {}} for a, s in zip("abc", [0.9, 0.95, 0.93])}}
    >>> sequence_verdict(summarize(df), "s", ev)["ranking"]
    ['b', 'c', 'a']
    >>> v = first_rule(summarize(df), "s", ev)
    >>> v["best"], v["ranking"], v["basis"]
    ('a', ['a', 'c', 'b'], ['agreement', 'corners_canonical'])
    """
    v = sequence_verdict(summary, sequence, evidence)
    keep = {k: v[k] for k in ("sequence", "best", "ranking", "basis")}
    if evidence is None or v["basis"][:1] != ["agreement"]:
        return keep  # ground truth, or corners alone, decided: the rules agree
    if not evidence.get("majority", True):
        # the first rule had no agreeing groups (issue 41, 2026-11-28): without a majority
        # it abstained
        return {**keep, "best": None}
    block = summary.xs(sequence, level="sequence")
    algorithms = [a for a in block.index if str(a).lower() not in GROUND_TRUTH_ALGORITHMS]
    confirmed = [a for a in v["ranking"] if a in _confirmed(evidence, algorithms)]
    n = len(confirmed)
    if v["ranking"][:n] != confirmed:
        raise RuntimeError(f"{sequence}: the shipped verdict's confirmed maps "
                           f"{v['ranking'][:n]} are not the ones the frozen first rule finds "
                           f"({confirmed}): the shipped rule's flags changed; update "
                           "_confirmed")
    key, corners = _first_rule_corner_key(block.loc[confirmed])
    if key is None or n < 2:
        return keep  # the confirmed maps are ordered by their support, as shipped
    head = sorted(confirmed, key=lambda a: (float(corners[a]), a))
    return {"sequence": keep["sequence"], "best": head[0] if v["best"] is not None else None,
            "ranking": head + v["ranking"][n:], "basis": ["agreement", key]}


def by_eye_agreement(eye: pd.DataFrame, folder: str, ranking: Sequence[str]
                     ) -> tuple[int, int]:
    """(concordant, counted) pairs of a ranking against the by-eye classes of one folder:
    pairs of maps in different classes, concordant when the better class comes first."""
    cls = dict(zip(eye.loc[eye["folder"] == folder, "map"],
                   eye.loc[eye["folder"] == folder, "class"]))
    pos = {m: i for i, m in enumerate(ranking)}
    good = total = 0
    names = [m for m in cls if m in pos]
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            if cls[a] == cls[b]:
                continue
            total += 1
            better, worse = (a, b) if cls[a] < cls[b] else (b, a)
            good += pos[better] < pos[worse]
    return good, total


def markdown(bench: pd.DataFrame | None, eye: pd.DataFrame | None,
             verdicts: dict[str, dict[str, Any]] | None, command: str) -> str:
    """The tables of docs/validity.md's verdict section."""
    out = [f"Regenerate: `{command}`\n"]
    if bench is not None and len(bench):
        out.append("\n**Benchmark, ground truth hidden** (one row per set of sequences; the "
                   "old rule, corners alone, in brackets):\n\n"
                   "| sequences | n | named in ATE top two | abstained | named a run > 3x "
                   "the best ATE (broken) | first rule (2026-11-25): top two, broken |"
                   "\n|---|---|---|---|---|---|\n")
        seed = bench["sequence"].str.rsplit("-", n=1).str[1]
        other = bench["sequence"].str.contains(f"-{OTHER_GENERATOR[1]}-", regex=False)
        groups = [(label, seed.isin(seeds) & ~other) for label, seeds in BENCHMARK_SETS]
        groups += [(OTHER_GENERATOR[0], other), ("all", seed == seed)]
        for label, mask in groups:
            b = bench[mask]
            if not len(b):
                continue
            top2 = int((b["ate_rank"] <= 2).sum())
            old2 = int((b["old_ate_rank"] <= 2).sum())
            first2 = int((b["first_ate_rank"] <= 2).sum())
            out.append(f"| {label} | {len(b)} | {top2} ({100 * top2 / len(b):.0f}%) "
                       f"[{old2} ({100 * old2 / len(b):.0f}%)] | "
                       f"{int(b['best'].isna().sum())} [{int(b['old_best'].isna().sum())}] | "
                       f"{int(b['broken_named'].sum())} [{int(b['old_broken_named'].sum())}] | "
                       f"{first2} ({100 * first2 / len(b):.0f}%), "
                       f"{int(b['first_broken_named'].sum())} |\n")
        bad = bench[bench["broken_named"] | (bench["ate_rank"] > 2)]
        if len(bad):
            out.append("\nSequences where the named algorithm is not in the ATE top two or is "
                       "broken: " + "; ".join(
                           f"{r.sequence} ({r.best}, {r.ate_ratio:.1f}x the best ATE)"
                           for r in bad.itertuples()) + ".\n")
    if eye is not None and verdicts:
        out.append("\n**Real folders, against the by-eye classes** (ranked by eye before the "
                   "rule existed; the first run on them is above):\n\n"
                   "| folder | named best | its class | broken named | pairs concordant | "
                   "ranking | confidence |\n|---|---|---|---|---|---|---|\n")
        good_all = total_all = first_all = 0
        for folder, v in verdicts.items():
            sub = eye[eye["folder"] == folder].set_index("map")
            best = v["best"]
            good, total = by_eye_agreement(eye, folder, v["ranking"])
            good_all += good
            total_all += total
            if "first_rule" in v:
                first_all += by_eye_agreement(eye, folder, v["first_rule"]["ranking"])[0]
            cls = "-" if best is None else str(sub.loc[best, "class"])
            broken = "-" if best is None else ("**yes**" if sub.loc[best, "broken"] else "no")
            share = f"{good}/{total}" if total else "-"
            out.append(f"| {folder} | {best or 'none (abstains)'} | {cls} | {broken} | "
                       f"{share} | {', '.join(v['ranking'])} | {v['confidence']} |\n")
        if total_all:
            out.append(f"\nPooled: {good_all}/{total_all} pairs concordant "
                       f"({good_all / total_all:.2f}); the first rule (2026-11-25) on the "
                       f"same maps: {first_all}/{total_all} ({first_all / total_all:.2f}).\n")
    return "".join(out)


def main(argv: Sequence[str] | None = None) -> int:
    """``python studies/verdict_study.py``: the verdict-validation tables."""
    ap = argparse.ArgumentParser(prog="python studies/verdict_study.py",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--benchmark", type=Path, nargs="+",
                    help="slamq run outputs of generated sequences")
    ap.add_argument("--align", default="auto",
                    help="how the maps are laid over each other (slamq.agreement's align)")
    ap.add_argument("--real", nargs=2, type=Path, metavar=("MAPS", "BY_EYE_CSV"),
                    help="the real maps' root folder and the by-eye classes")
    ap.add_argument("--no-defects", action="store_true",
                    help="agreement alone, without the defect detectors")
    ap.add_argument("--fill-scans", action="store_true",
                    help="records without scans get their sequence's rawlog (with_scans)")
    ap.add_argument("--markdown", type=Path, help="write into this file's section")
    a = ap.parse_args(argv)
    bench = (pd.concat([benchmark_verdicts(b, align=a.align, defects=not a.no_defects,
                                           fill_scans=a.fill_scans)
                        for b in a.benchmark], ignore_index=True) if a.benchmark else None)
    eye, verdicts = (folder_verdicts(*a.real, defects=not a.no_defects) if a.real
                     else (None, None))
    command = "python studies/verdict_study.py " + " ".join(
        sys.argv[1:] if argv is None else list(argv))
    return print_or_write_section(markdown(bench, eye, verdicts, command), a.markdown,
                                  BEGIN, END)


if __name__ == "__main__":
    sys.exit(main())
