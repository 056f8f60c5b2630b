"""A second wall direction another program's map draws too is the building's (candidate S1
of docs/validity.md, "A second generator the rule was not tuned on: wing worlds";
``slamq.verdict.rule.SHARED_DIRECTION``), beside the rule as shipped, on the generated sets
at both readings of rbpf-slam (its particles' mean path, and the path its map is drawn
at), with and without the maps' own scans.

Usage (from the repository's root; each set's evidence cached by ``scans_study.py``, and
``rbpf_path_study.py OUTPUT --travel`` run once for the map's path)::

    PYTHONPATH=studies python studies/shared_direction_study.py studies/scans-benchmark-ac-runs ...

Prints, per set and reading, the sequences (and with ``--pairs`` the pairs) in the ATE
top two (the better of two) and the broken runs named under each rule, and every verdict
S1, S1-5 (S1 with a 5-degree margin, docs/validity.md, "A 5-degree margin for S1") and S1a
(S1 lifting only by a map that agrees with the flagged one, "S1a: a second direction
lifted only by a map that agrees") and S1a-5 (S1a with a 5-degree margin, "S1a with a
5-degree margin on a third held-out set") and S1a-5s (5 degrees only where both maps have
their scans, "S1a-5 only where both maps have their scans") change ("before": the rule
before S1).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import rbpf_path_study as R
import scans_study as S

SHIPPED = (*R.RULE, S.CORRIDOR_AND_WHOLE, S.SPLIT_MEET)
# each rule names its margins, with both maps' scans and without (dirdeg0)
RULES = {"before": (*SHIPPED, S.DIR_OWN),
         "S1": (*SHIPPED, S.DIR_SHARED, "dirdeg=3", "dirdeg0=3"),
         "S1-5": (*SHIPPED, S.DIR_SHARED, "dirdeg=5", "dirdeg0=5"),
         "S1a": (*SHIPPED, S.DIR_AGREE, "dirdeg=3", "dirdeg0=3"),
         "S1a-5": (*SHIPPED, S.DIR_AGREE, "dirdeg=5", "dirdeg0=5"),
         "S1a-5s": (*SHIPPED, S.DIR_AGREE, "dirdeg=5", "dirdeg0=3")}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    ap.add_argument("output", type=Path, nargs="+", help="slamq run outputs of generated sets")
    ap.add_argument("--pairs", action="store_true", help="the two-map cases too")
    a = ap.parse_args(argv)
    for scans in (True, False):
        print(f"\n## {'With' if scans else 'Without'} the maps' own scans")
        R.compare_sets(a.output, {n: r if scans else (*r, S.NO_SCANS)
                                  for n, r in RULES.items()}, a.pairs)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
