"""Maps corners cannot compare: support against their own scans ordering them, on the
generated sets at the mean path and at each map's own path (docs/validity.md, "Maps
corners cannot compare: the scans order them").

Usage (from the repository's root; each set's evidence cached by ``scans_study.py`` and
rbpf-slam's most likely path by ``rbpf_path_study.py``)::

    PYTHONPATH=studies python studies/uncomparable_study.py studies/scans-benchmark-h-runs ...

Sets B-K are read with the split shares of ``split-v300-rows.csv`` (``--c2`` of
``rbpf_path_study.py``). Prints, per set and reading, the sequences in the ATE top two and
the broken runs named under both rules, and every verdict that changes.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd
import rbpf_path_study as R
import scans_study as S

OFF = (*R.RULE, S.UNCOMPARABLE_OFF)
ON = (*R.RULE, S.UNCOMPARABLE_ON)
C2 = {f"scans-benchmark-{x}-runs" for x in "bcdefghijk"}


def one_set(out: Path) -> list[dict]:
    """The rows of one set: per reading and rule, top two and broken named; and the
    changed verdicts printed."""
    rows = R.compare_rules(out, {"support": OFF, "scans": ON}, out.name in C2)
    return [{("sequences" if k == "cases" else k.replace("top ", "top2 ")): v
             for k, v in r.items()} for r in rows]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    ap.add_argument("output", type=Path, nargs="+", help="slamq run outputs of generated sets")
    a = ap.parse_args(argv)
    rows = [r for out in a.output for r in one_set(out)]
    table = pd.DataFrame(rows)
    print(table.to_string(index=False))
    print(table.groupby("reading").sum(numeric_only=True).to_string())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
