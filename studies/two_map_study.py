"""The verdict on two maps of one place, on real maps ranked by eye (issue 41, item 5;
docs/validity.md, "Two maps on real folders").

``python studies/two_map_study.py --real ../shared/data/maps studies/by_eye_pairs.csv
studies/by_eye.csv --markdown docs/validity.md`` regenerates the tables.

- :func:`pair_verdicts`: every pair of two maps of one folder of by-eye CSVs (``folder,
  map, class, broken``; class 1 best; studies/by_eye.csv, studies/by_eye_pairs.csv),
  judged alone as ``slamq verdict MAP_A MAP_B`` judges it
  (:func:`slamq.verdict.maps.maps_verdict`, defect detectors on, no scans), with the
  outcome against the by-eye classes and why an undecided pair was not decided.
- :func:`tally`: pairs, decided, right, wrong, broken named, abstained, for pairs of
  different classes and for pairs of one class (ties: naming either is right).
"""

from __future__ import annotations

import argparse
import itertools
import math
import sys
from collections import Counter
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import pandas as pd
from _common import print_or_write_section

from slamq.verdict.maps import maps_verdict
from slamq.verdict.rule import COMPLETE_SHARE

__all__ = ["cause", "main", "markdown", "pair_verdicts", "tally"]

BEGIN, END = "<!-- two-map-study:begin -->", "<!-- two-map-study:end -->"


def cause(evidence: dict[str, Any] | None, names: Sequence[str]) -> str:
    """Why the two-map rule without scans cannot decide a pair, from its evidence: a map
    not placed, no defect flag on either map, both flagged, or the unflagged one partial
    ("-" when the evidence would let it decide).

    Examples
    --------
    >>> e = {"algorithms": {
    ...     "a": {"placed": True, "runs": 1, "flagged_runs": 0, "completeness": 1.0},
    ...     "b": {"placed": True, "runs": 1, "flagged_runs": 1, "completeness": 0.5}}}
    >>> cause(e, ["a", "b"])
    '-'
    >>> e["algorithms"]["b"]["flagged_runs"] = 0
    >>> cause(e, ["a", "b"])
    'no defect flag on either map'
    >>> e["algorithms"]["a"]["placed"] = False
    >>> cause(e, ["a", "b"])
    'not placed (frames do not fit, registration refused)'
    """
    if evidence is None:
        return "a map could not be read"
    info = evidence["algorithms"]
    if any(not info[n]["placed"] for n in names):
        return "not placed (frames do not fit, registration refused)"
    flagged = [n for n in names if info[n]["flagged_runs"]
               and 2 * info[n]["flagged_runs"] >= info[n]["runs"]]
    if not flagged:
        return "no defect flag on either map"
    if len(flagged) == 2:
        return "both maps carry a defect flag"
    complete = [float(info[n]["completeness"]) for n in names]
    other = next(n for n in names if n not in flagged)
    most = max((c for c in complete if math.isfinite(c)), default=math.nan)
    if float(info[other]["completeness"]) < COMPLETE_SHARE * most:
        return "the unflagged map is partial"
    return "-"


def _flags(evidence: dict[str, Any] | None, name: str) -> str:
    """What the evidence holds against one map of a pair: its defect kinds, "not placed",
    "partial" (completeness below ``COMPLETE_SHARE`` of the other's); "" when nothing."""
    if evidence is None or name not in evidence["algorithms"]:
        return "not read"
    info = evidence["algorithms"]
    e = info[name]
    out = sorted({d["kind"] for ds in e["defects"].values() for d in ds})
    out += [] if e["placed"] else ["not placed"]
    most = max((float(x["completeness"]) for x in info.values()
                if math.isfinite(float(x["completeness"]))), default=math.nan)
    out += ["partial"] if float(e["completeness"]) < COMPLETE_SHARE * most else []
    return ", ".join(out)


def pair_verdicts(root: Path, by_eye: Sequence[Path], *, threads: int | None = None
                  ) -> pd.DataFrame:
    """The verdict on every pair of two maps of one folder of the by-eye CSVs.

    Parameters
    ----------
    root : path
        The folder the CSVs' ``folder`` column is relative to.
    by_eye : sequence of path
        CSVs with ``folder, map, class, broken`` (class 1 best; broken 1 or 0).
    threads : int, optional
        Cap on the Rust worker threads.

    Returns
    -------
    pandas.DataFrame
        One row per pair: ``folder, map_a, map_b, class_a, class_b, maps`` (how many maps
        the folder has), ``kind`` ("different" or "tie"), ``best`` (None: abstained),
        ``outcome`` ("right", "wrong", "abstained"; for ties "decided" or "abstained"),
        ``broken_named``, ``reason`` (the verdict's confidence), ``cause`` (:func:`cause`) and
        ``flags_a``, ``flags_b`` (each map's defect kinds, "not placed", "partial").
    """
    rows = []
    for csv in by_eye:
        eye = pd.read_csv(csv)
        eye = eye[pd.to_numeric(eye["class"], errors="coerce").notna()]
        for folder, sub in eye.groupby("folder", sort=False):
            cls = {str(r["map"]): int(r["class"]) for _, r in sub.iterrows()}
            broken = {str(r["map"]): bool(int(r["broken"])) for _, r in sub.iterrows()}
            for a, b in itertools.combinations(list(cls), 2):
                res = maps_verdict([Path(root) / str(folder) / a, Path(root) / str(folder) / b],
                                   names=[a, b], threads=threads)
                v = res["verdict"] or {"best": None, "confidence": "none: no map read"}
                best = v["best"] if v["best"] in (a, b) else None
                kind = "tie" if cls[a] == cls[b] else "different"
                if best is None:
                    outcome = "abstained"
                elif kind == "tie":
                    outcome = "decided"
                else:
                    outcome = "right" if cls[best] == min(cls[a], cls[b]) else "wrong"
                rows.append({"folder": folder, "map_a": a, "map_b": b, "class_a": cls[a],
                             "class_b": cls[b], "maps": len(cls), "kind": kind, "best": best,
                             "outcome": outcome,
                             "broken_named": bool(best is not None and broken[best]),
                             "reason": str(v["confidence"]),
                             "cause": cause(res["evidence"], [a, b]) if best is None else "-",
                             "flags_a": _flags(res["evidence"], a),
                             "flags_b": _flags(res["evidence"], b),
                             "errors": "; ".join(e for _, e in res["errors"])})
    return pd.DataFrame(rows)


def tally(pairs: pd.DataFrame) -> dict[str, dict[str, Any]]:
    """Counts per kind of pair (``different``, ``tie``): ``pairs, decided, right, wrong,
    broken_named, abstained`` and the abstentions' ``reasons`` and ``causes``
    (:class:`collections.Counter`).

    Examples
    --------
    >>> p = pd.DataFrame({"kind": ["different", "different", "tie"],
    ...                   "outcome": ["right", "abstained", "abstained"],
    ...                   "broken_named": [False, False, False],
    ...                   "reason": ["low: ...", "none: why", "none: why"],
    ...                   "cause": ["-", "x", "x"]})
    >>> t = tally(p)
    >>> t["different"]["pairs"], t["different"]["decided"], t["different"]["right"]
    (2, 1, 1)
    >>> t["tie"]["abstained"], dict(t["tie"]["causes"])
    (1, {'x': 1})
    """
    out = {}
    for kind in ("different", "tie"):
        p = pairs[pairs["kind"] == kind]
        abst = p[p["outcome"] == "abstained"]
        out[kind] = {"pairs": len(p), "decided": int((p["outcome"] != "abstained").sum()),
                     "right": int((p["outcome"] == "right").sum()),
                     "wrong": int((p["outcome"] == "wrong").sum()),
                     "broken_named": int(p["broken_named"].sum()),
                     "abstained": len(abst),
                     "reasons": Counter(r.removeprefix("none: ") for r in abst["reason"]),
                     "causes": Counter(abst["cause"])}
    return out


def _group_rows(pairs: pd.DataFrame, label: str) -> list[str]:
    t = tally(pairs)
    d, e = t["different"], t["tie"]
    return [f"| {label} | {d['pairs']} | {d['decided']} | {d['right']} | {d['wrong']} | "
            f"{d['broken_named']} | {d['abstained']} | {e['pairs']} | {e['decided']} | "
            f"{e['abstained']} |\n"]


def markdown(pairs: pd.DataFrame, command: str) -> str:
    """The tables of docs/validity.md's two-map section."""
    out = [f"Regenerate: `{command}`\n\n"
           "| pairs | different classes | decided | right | wrong | broken named | "
           "abstained | tie pairs | decided | abstained |\n"
           "|---|---|---|---|---|---|---|---|---|---|\n"]
    two = pairs[pairs["maps"] == 2]
    more = pairs[pairs["maps"] > 2]
    if len(two):
        out += _group_rows(two, "two-map folders")
    if len(more):
        out += _group_rows(more, "drawn from folders of 3+ maps")
    out += _group_rows(pairs, "all")
    t = tally(pairs)
    for kind, label in (("different", "different classes"), ("tie", "one class")):
        if t[kind]["abstained"]:
            out.append(f"\nWhy the pairs of {label} were not decided: the verdict's reasons "
                       + "; ".join(f"{n} x \"{r}\"" for r, n in t[kind]["reasons"].most_common())
                       + "; from the evidence: "
                       + "; ".join(f"{c}: {n}" for c, n in t[kind]["causes"].most_common())
                       + ".\n")
    out.append("\n| folder | map A (class): held against it | map B (class): held against "
               "it | named | outcome | why not decided |\n|---|---|---|---|---|---|\n")
    for r in pairs.itertuples():
        best = r.best if isinstance(r.best, str) else "-"
        out.append(f"| {r.folder} | {r.map_a} ({r.class_a}): {r.flags_a or '-'} | "
                   f"{r.map_b} ({r.class_b}): {r.flags_b or '-'} | {best} | {r.outcome}"
                   f"{' (**broken**)' if r.broken_named else ''} | {r.cause} |\n")
    return "".join(out)


def main(argv: Sequence[str] | None = None) -> int:
    """``python studies/two_map_study.py``: the two-map verdict against by-eye classes."""
    ap = argparse.ArgumentParser(prog="python studies/two_map_study.py",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--real", nargs="+", type=Path, required=True,
                    metavar="MAPS BY_EYE_CSV",
                    help="the real maps' root folder, then one or more by-eye CSVs")
    ap.add_argument("--threads", type=int, help="cap on the Rust worker threads")
    ap.add_argument("--csv", type=Path, help="also write the per-pair rows here")
    ap.add_argument("--markdown", type=Path, help="write into this file's section")
    a = ap.parse_args(argv)
    if len(a.real) < 2:
        ap.error("--real needs the maps folder and at least one by-eye CSV")
    pairs = pair_verdicts(a.real[0], a.real[1:], threads=a.threads)
    if a.csv:
        pairs.to_csv(a.csv, index=False)
    args = list(sys.argv[1:] if argv is None else argv)
    if "--csv" in args:  # a side output, not part of the table's command
        i = args.index("--csv")
        del args[i:i + 2]
    command = "python studies/two_map_study.py " + " ".join(args)
    return print_or_write_section(markdown(pairs, command), a.markdown, BEGIN, END)


if __name__ == "__main__":
    sys.exit(main())
