"""How often each confidence level of the verdict is right, on every labelled set there is
(issue 41, item 6; docs/validity.md, "Calibrated confidence").

``python studies/confidence_study.py --benchmark studies/benchmark-holdout-runs ...
--real ../shared/data/maps studies/by_eye.csv --real2d examples/real2d-runs/verdicts.csv
--markdown docs/validity.md`` regenerates the table. The verdict quotes its "all" rows
(``slamq.verdict.calibration.CONFIDENCE_CALIBRATION``): copy changed counts there, or
``tests/report/test_verdict_calibration.py`` fails.

A verdict's level is the first word of its ``confidence`` ("high", "medium", "low";
"none" when it abstains). It is *right* when:

- generated benchmark (ground truth hidden from the verdict): the named algorithm is in the
  ATE top two of its sequence and its ATE is at most 3x the best (not a broken run);
- real folders ranked by eye (studies/by_eye.csv): the named map is in the folder's best
  by-eye class and not marked broken;
- real logs with relations (``studies/real2d_validity.py``'s ``verdicts.csv``): the named
  program is in the top two by the relations error and at most 3x the best;
- pairs of two maps (``--pairs``: the pair verdicts ``studies/scans_study.py`` wrote into a
  run folder, generated or real logs; ``--pairs-real``: ``studies/two_map_study.py``'s pairs
  of real maps with by-eye or ATE classes): the named map is the better of the two by the
  truth (or as good) and not broken. A verdict of two maps says "low: two maps; ..." and is
  counted apart, as level "low (two maps)": the verdict quotes that record for it.

Each level gets its count, the share right and the lower end of its 95% Wilson interval:
a level may call itself "high" only when that lower end is at least 0.95 (the issue's bar
is the share; the interval says how much the share can be trusted on the counts there are).
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence
from pathlib import Path

import pandas as pd
from _common import print_or_write_section
from scans_study import rule_name
from verdict_study import benchmark_verdicts, folder_verdicts

from slamq.verdict.calibration import (  # one definition: the verdict's own
    TWO_MAPS,
    level_of,
    wilson_lower,
)
from slamq.verdict.rule import SCAN_FLOOR, SCAN_SHARE

__all__ = ["level", "wilson_lower", "calibration", "markdown", "main"]

BEGIN, END = "<!-- confidence-study:begin -->", "<!-- confidence-study:end -->"
LEVELS = ("high", "medium", "low", TWO_MAPS, "none")


def level(confidence: object) -> str:
    """The level of a verdict's ``confidence`` text (a verdict of two maps: its own,
    ``"low (two maps)"``, as :func:`slamq.verdict.calibration.level_of` reads it).

    Examples
    --------
    >>> level("medium: no ground truth; the maps confirm each other"), level(None)
    ('medium', 'none')
    >>> level("low: two maps; b is wrong on its own")
    'low (two maps)'
    """
    if not isinstance(confidence, str) or not confidence:
        return "none"
    word = level_of(confidence)
    return word if word in LEVELS else "none"


def benchmark_rows(outputs: Sequence[Path], *, fill_scans: bool = False,
                   most_likely: bool = False) -> list[dict]:
    """One row per generated sequence: set, level, named, right (``fill_scans``: records
    without scans get their sequence's recording, ``verdict_study.with_scans``;
    ``most_likely``: rbpf-slam read at the path its map is drawn at, its ATE too)."""
    rows = []
    for out in outputs:
        for r in benchmark_verdicts(Path(out), fill_scans=fill_scans,
                                    most_likely=most_likely).itertuples():
            named = isinstance(r.best, str)
            rows.append({"data": f"generated{' (map path)' if most_likely else ''}: "
                                 f"{Path(out).name}", "item": r.sequence,
                         "level": level(r.reason) if named else "none", "named": named,
                         "right": bool(named and r.ate_rank <= 2 and not r.broken_named)})
    return rows


def folder_rows(root: Path, by_eye: Path) -> list[dict]:
    """One row per real folder ranked by eye."""
    eye, verdicts = folder_verdicts(Path(root), Path(by_eye))
    rows = []
    for folder, v in verdicts.items():
        block = eye[eye["folder"] == folder].set_index("map")
        best = v.get("best")
        named = isinstance(best, str) and best in block.index
        right = bool(named and block.loc[best, "class"] == block["class"].min()
                     and not block.loc[best, "broken"])
        rows.append({"data": "real folders ranked by eye", "item": folder,
                     "level": level(v.get("confidence")) if named else "none",
                     "named": named, "right": right})
    return rows


def real2d_rows(verdicts_csv: Path) -> list[dict]:
    """One row per verdict of ``studies/real2d_validity.py`` (real logs, relations)."""
    df = pd.read_csv(verdicts_csv)
    rows = []
    for r in df.itertuples():
        named = isinstance(r.best, str) and r.best != ""
        right = bool(named and r.rank <= 2 and r.ratio <= 3.0)
        rows.append({"data": "real logs, relations error", "item": f"{r.sequence}/{r.iteration}",
                     "level": level(r.confidence) if named else "none", "named": named,
                     "right": right})
    return rows


def pair_rows(outputs: Sequence[Path]) -> list[dict]:
    """One row per pair of programs in the pair verdicts ``studies/scans_study.py`` wrote
    into each run folder (``scans-verdicts-pairs-crossing_share.csv``, the rule as
    shipped, each map with its own scans; or the file named, as the rule applied to the
    folder's cached evidence with the split rows beside it, ``--cached --figure c2``):
    right when the named program's truth (ATE, or the relations error on the real logs)
    is the lower of the two (or equal) and it is not broken."""
    rule = rule_name((SCAN_FLOOR, SCAN_SHARE))
    rows = []
    for out in outputs:
        out = Path(out)
        csv = out if out.suffix == ".csv" else out / "scans-verdicts-pairs-crossing_share.csv"
        out = csv.parent
        df = pd.read_csv(csv)
        for r in df.to_dict("records"):
            best = r[f"best@{rule}"]
            named = isinstance(best, str) and best != ""
            right = bool(named and float(r[f"ratio@{rule}"]) <= 1.0 + 1e-9
                         and not bool(r[f"broken_named@{rule}"]))
            rows.append({"data": f"pairs: {Path(out).name}", "item": r["case"],
                         "level": level(r[f"reason@{rule}"]) if named else "none",
                         "named": named, "right": right})
    return rows


def real_pair_rows(root: Path, csvs: Sequence[Path]) -> list[dict]:
    """One row per pair of maps of one folder of each classes CSV
    (:func:`two_map_study.pair_verdicts`): right when the named map is of the better
    class (either, of one class) and not broken."""
    from two_map_study import pair_verdicts

    rows = []
    for csv in csvs:
        for r in pair_verdicts(Path(root), [Path(csv)]).itertuples():
            named = isinstance(r.best, str)
            rows.append({"data": f"pairs: {Path(csv).stem}",
                         "item": f"{r.folder}: {r.map_a} | {r.map_b}",
                         "level": level(r.reason) if named else "none", "named": named,
                         "right": bool(named and r.outcome in ("right", "decided")
                                       and not r.broken_named)})
    return rows


def calibration(rows: pd.DataFrame) -> pd.DataFrame:
    """Per data set and level (and over all data): verdicts, right, share right, Wilson
    lower bound.

    Examples
    --------
    >>> rows = pd.DataFrame({"data": ["a"] * 3, "level": ["medium", "medium", "low"],
    ...                      "named": [True] * 3, "right": [True, False, True]})
    >>> calibration(rows)[["data", "level", "n", "right"]].values.tolist()
    [['a', 'medium', 2, 1], ['a', 'low', 1, 1], ['all', 'medium', 2, 1], ['all', 'low', 1, 1]]
    """
    out = []
    for data, block in [*rows.groupby("data", sort=False), ("all", rows)]:
        for lv in LEVELS:
            b = block[block["level"] == lv]
            if not len(b):
                continue
            n, right = len(b), int(b["right"].sum())
            out.append({"data": data, "level": lv, "n": n, "right": right,
                        "share": right / n if lv != "none" else math.nan,
                        "wilson_lower": wilson_lower(right, n) if lv != "none" else math.nan})
    return pd.DataFrame(out)


def markdown(table: pd.DataFrame, command: str) -> str:
    """The calibration table as Markdown."""
    lines = [f"Regenerate: `{command}`\n\n",
             "| data | level | verdicts | right | share right | 95% lower bound |\n",
             "|---|---|---|---|---|---|\n"]
    for r in table.itertuples():
        if r.level == "none":
            lines.append(f"| {r.data} | abstained | {r.n} | - | - | - |\n")
        else:
            lines.append(f"| {r.data} | {r.level} | {r.n} | {r.right} | {r.share:.2f} | "
                         f"{r.wilson_lower:.2f} |\n")
    return "".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    ap.add_argument("--benchmark", nargs="+", default=[], type=Path,
                    help="slamq run outputs of generated sequences")
    ap.add_argument("--real", nargs=2, metavar=("MAPS", "BY_EYE_CSV"), type=Path,
                    help="the real maps' root folder and the by-eye classes")
    ap.add_argument("--real2d", type=Path, help="verdicts.csv of studies/real2d_validity.py")
    ap.add_argument("--fill-scans", action="store_true",
                    help="records without scans get their sequence's rawlog, as slamq run "
                    "records it now")
    ap.add_argument("--pairs", nargs="+", default=[], type=Path, metavar="DIR",
                    help="run folders holding studies/scans_study.py's pair verdicts "
                    "(or a pair verdicts file in one)")
    ap.add_argument("--pairs-real", nargs="+", default=[], type=Path,
                    metavar="MAPS CLASSES_CSV",
                    help="the real maps' root folder, then CSVs of classes "
                    "(studies/two_map_study.py judges every pair of each folder)")
    ap.add_argument("--most-likely", action="store_true",
                    help="the generated sets with rbpf-slam read at the path its map is "
                    "drawn at, its ATE too (docs/validity.md, \"rbpf-slam read wholly at "
                    "its most likely path\")")
    ap.add_argument("--markdown", type=Path, help="write into this file's section")
    args = ap.parse_args(argv)
    rows: list[dict] = benchmark_rows(args.benchmark, fill_scans=args.fill_scans,
                                      most_likely=args.most_likely)
    if args.real:
        rows += folder_rows(*args.real)
    if args.real2d:
        rows += real2d_rows(args.real2d)
    rows += pair_rows(args.pairs)
    if args.pairs_real:
        if len(args.pairs_real) < 2:
            ap.error("--pairs-real needs the maps folder and at least one classes CSV")
        rows += real_pair_rows(args.pairs_real[0], args.pairs_real[1:])
    if not rows:
        ap.error("give at least one of --benchmark, --real, --real2d, --pairs, --pairs-real")
    frame = pd.DataFrame(rows)
    wrong = frame[frame["named"] & ~frame["right"]]
    generated_pairs = wrong["data"].str.startswith("pairs: ") & wrong["item"].str.startswith(
        "gen-")
    wrong = wrong[~generated_pairs]  # counted in the table; too many to list
    command = "python studies/confidence_study.py " + " ".join(
        sys.argv[1:] if argv is None else argv)
    text = markdown(calibration(frame), command)
    if len(wrong):
        text += "\nWrong picks (generated pairs: counted above, not listed): " + ", ".join(
            f"{r.item} ({r.level})" for r in wrong.itertuples()) + ".\n"
    return print_or_write_section(text, args.markdown, BEGIN, END)


if __name__ == "__main__":
    raise SystemExit(main())
