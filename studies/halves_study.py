"""The halves' precision where the maps disagree: the path whose halves cross each other's
walls the least where they meet named (candidate P1, the travel veto after it; P1b,
without; P1c, no travel veto for any named map the halves separate so), beside the rule as
shipped, on generated sets at rbpf-slam's mean path and at its most likely one
(docs/validity.md, "The halves' precision where the maps disagree" and "Exempt from the
travel veto where the halves separate the paths").

Usage (from the repository's root; each set's evidence cached by ``scans_study.py`` and
``rbpf_path_study.py --travel``)::

    PYTHONPATH=studies python studies/halves_study.py studies/scans-benchmark-ai-runs --pairs

Prints, per set and reading, the sequences (and with ``--pairs`` the pairs) in the ATE
top two (the better of two) and the broken runs named under each rule, and every verdict
a candidate changes. On the real logs: ``scans_study.py real ... --halves``.
"""

from __future__ import annotations

import rbpf_path_study as R
import scans_study as S

BEFORE = (*R.RULE, S.HALVES_OFF)  # "shipped" in the tables: the rule before 2026-12-02
P1 = (*R.RULE, S.HALVES)
P1B = (*R.RULE, S.HALVES_ALONE)
P1C = (*R.RULE, S.HALVES_ANY)  # shipped since


def main(argv: list[str] | None = None) -> int:
    return R.comparison_main(argv, __doc__, {"shipped": BEFORE, "P1": P1, "P1b": P1B,
                                                "P1c": P1C})


if __name__ == "__main__":
    raise SystemExit(main())
