"""Paths shortened along the corridors, not everywhere: the travel veto reading the
shortfall along a recording's corridors beyond the shortfall elsewhere (candidate T2), or
vetoing only where both it and the whole path's are short (T2-and, shipped since), beside
the veto on the whole path (the rule before), on the generated sets at both readings of
rbpf-slam (docs/validity.md, "Paths shortened along the corridors, not everywhere").

Usage (from the repository's root; each set's evidence cached by ``scans_study.py``)::

    PYTHONPATH=studies python studies/corridor_travel_study.py studies/scans-benchmark-x-runs ...

Prints, per set and reading, the sequences (and with ``--pairs`` the pairs) in the ATE
top two (the better of two) and the broken runs named under each rule, and every
verdict a candidate changes. A set with ``split-v300-rows.csv`` is read with those split
shares.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd
import rbpf_path_study as R
import scans_study as S

# each with the split share read as it was then (before "A split share confirms a path
# only where its halves meet")
WHOLE = (*R.RULE, S.WHOLE_PATH, S.SPLIT_ANYWHERE)  # the veto before 2026-11-30 ("shipped")
T2 = (*R.RULE, S.CORRIDOR_TRAVEL, S.SPLIT_ANYWHERE)
T2_AND = (*R.RULE, S.CORRIDOR_AND_WHOLE, S.SPLIT_ANYWHERE)  # shipped since


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    ap.add_argument("output", type=Path, nargs="+", help="slamq run outputs of generated sets")
    ap.add_argument("--pairs", action="store_true", help="the two-map cases too")
    a = ap.parse_args(argv)
    for pair in (False, True) if a.pairs else (False,):
        rules = {"whole path": WHOLE, "T2": T2, "T2-and": T2_AND}
        rows = [r for out in a.output for r in R.compare_rules(
            out, rules, (out / "split-v300-rows.csv").exists(), pair=pair)]
        table = pd.DataFrame(rows)
        print(f"\n{'Pairs' if pair else 'Sequences'}:\n")
        print(table.to_string(index=False))
        print(table.groupby("reading").sum(numeric_only=True).to_string())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
