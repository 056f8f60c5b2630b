"""Doubled walls alone do not decide two maps (candidate D1 of docs/validity.md, "Doubled
walls alone do not decide two maps"; ``slamq.verdict.rule.MILD_DEFECTS_DECIDE``), beside
the rule before, on the generated sets at both readings of rbpf-slam (its particles' mean
path, and the path its map is drawn at), with and without the maps' own scans.

Usage (from the repository's root; each set's evidence cached by ``scans_study.py``, and
``rbpf_path_study.py OUTPUT --travel`` run once for the map's path)::

    PYTHONPATH=studies python studies/doubled_pairs_study.py studies/scans-benchmark-ab-runs ...

Prints, per set and reading, the pairs (and with ``--sequences`` the sequences) in the ATE
top two (the better of two) and the broken runs named under each rule, and every verdict
D1 changes: the rule before's pick, its rank and its ATE over the pair's best.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd
import rbpf_path_study as R
import scans_study as S

SHIPPED = (*R.RULE, S.CORRIDOR_AND_WHOLE, S.SPLIT_MEET)
RULES = {"before": (*SHIPPED, S.MILD_DECIDES), "D1": (*SHIPPED, S.MILD_NEEDS_SCANS),
         "before, no scans": (*SHIPPED, S.MILD_DECIDES, S.NO_SCANS),
         "D1, no scans": (*SHIPPED, S.MILD_NEEDS_SCANS, S.NO_SCANS)}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    ap.add_argument("output", type=Path, nargs="+", help="slamq run outputs of generated sets")
    ap.add_argument("--sequences", action="store_true", help="the sequences too")
    a = ap.parse_args(argv)
    for pair in (False, True) if a.sequences else (True,):
        rows = []
        for out in a.output:
            c2 = (out / "split-v300-rows.csv").exists()
            for with_scans in (True, False):
                names = [n for n in RULES if ("no scans" in n) != with_scans]
                got = R.compare_rules(out, {n: RULES[n] for n in names}, c2, pair=pair)
                rows += [{**r, "scans": with_scans, **{k.replace(", no scans", ""): v
                                                       for k, v in r.items()
                                                       if k.startswith(("top", "broken"))}}
                         for r in got]
        table = pd.DataFrame(rows)
        keep = ["set", "reading", "scans", "cases", "top before", "broken before", "top D1",
                "broken D1"]
        print(f"\n{'Pairs' if pair else 'Sequences'}:\n")
        print(table[keep].to_string(index=False))
        print(table[keep].groupby(["scans", "reading"]).sum(numeric_only=True).to_string())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
