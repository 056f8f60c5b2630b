"""A split share confirms a path only where its halves meet (O1 of docs/validity.md, "A
split share confirms a path only where its halves meet"; ``slamq.verdict.rule.SPLIT_MEET``,
shipped since), beside the rule before it ("shipped" in the tables), on the generated sets
at both readings of rbpf-slam (its particles' mean path, and the path its map is drawn
at).

Usage (from the repository's root; each set's evidence cached by ``scans_study.py``, and
``rbpf_path_study.py OUTPUT --travel`` run once for the map's path)::

    PYTHONPATH=studies python studies/split_meet_study.py studies/scans-benchmark-y-runs ...

Prints, per set and reading, the sequences (and with ``--pairs`` the pairs) in the ATE
top two (the better of two) and the broken runs named under each rule, and every verdict
O1 changes.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd
import rbpf_path_study as R
import scans_study as S

BEFORE = (*R.RULE, S.CORRIDOR_AND_WHOLE, S.SPLIT_ANYWHERE)  # "shipped" in the tables
O1 = (*R.RULE, S.CORRIDOR_AND_WHOLE, S.SPLIT_MEET)  # shipped since


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    ap.add_argument("output", type=Path, nargs="+", help="slamq run outputs of generated sets")
    ap.add_argument("--pairs", action="store_true", help="the two-map cases too")
    a = ap.parse_args(argv)
    for pair in (False, True) if a.pairs else (False,):
        rules = {"shipped": BEFORE, "O1": O1}
        rows = [r for out in a.output for r in R.compare_rules(
            out, rules, (out / "split-v300-rows.csv").exists(), pair=pair)]
        table = pd.DataFrame(rows)
        print(f"\n{'Pairs' if pair else 'Sequences'}:\n")
        print(table.to_string(index=False))
        print(table.groupby("reading").sum(numeric_only=True).to_string())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
