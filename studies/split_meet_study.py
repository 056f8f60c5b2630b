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

import rbpf_path_study as R
import scans_study as S

BEFORE = (*R.RULE, S.CORRIDOR_AND_WHOLE, S.SPLIT_ANYWHERE)  # "shipped" in the tables
O1 = (*R.RULE, S.CORRIDOR_AND_WHOLE, S.SPLIT_MEET)  # shipped since


def main(argv: list[str] | None = None) -> int:
    return R.comparison_main(argv, __doc__, {"shipped": BEFORE, "O1": O1})


if __name__ == "__main__":
    raise SystemExit(main())
