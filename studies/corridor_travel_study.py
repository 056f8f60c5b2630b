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

import rbpf_path_study as R
import scans_study as S

# each with the split share read as it was then (before "A split share confirms a path
# only where its halves meet")
WHOLE = (*R.RULE, S.WHOLE_PATH, S.SPLIT_ANYWHERE)  # the veto before 2026-11-30 ("shipped")
T2 = (*R.RULE, S.CORRIDOR_TRAVEL, S.SPLIT_ANYWHERE)
T2_AND = (*R.RULE, S.CORRIDOR_AND_WHOLE, S.SPLIT_ANYWHERE)  # shipped since


def main(argv: list[str] | None = None) -> int:
    return R.comparison_main(argv, __doc__, {"whole path": WHOLE, "T2": T2, "T2-and": T2_AND})


if __name__ == "__main__":
    raise SystemExit(main())
