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
import copy
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
    df, cache, figure, values, _, new_cache, new_values = R.load_set(out, out.name in C2)
    df_ml = R.most_likely_paths(df, out)
    rows = []
    for reading, d, c, v, truth in (("mean path", df, cache, values, "ate_rmse"),
                                    ("map's path", df_ml, new_cache, new_values, "ate_ml")):
        got = S.verdicts(d.assign(ate_ml=df_ml["ate_ml"]), truth, rules=(OFF, ON),
                         cache=copy.deepcopy(c), figure=figure, values=v)
        row = {"set": out.name, "reading": reading, "sequences": len(got)}
        for name, rule in (("support", OFF), ("scans", ON)):
            col = S.rule_name(rule)
            row[f"top2 {name}"] = int(((got[f"rank@{col}"] <= 2)
                                       & got[f"best@{col}"].notna()).sum())
            row[f"broken {name}"] = int(got[f"broken_named@{col}"].sum())
        a, b = S.rule_name(OFF), S.rule_name(ON)
        for _, r in got[got[f"best@{a}"].fillna("-") != got[f"best@{b}"].fillna("-")].iterrows():
            print(f"  {out.name} {reading}: {r['case']}: {r[f'best@{a}']} (rank "
                  f"{r[f'rank@{a}']}, {r[f'ratio@{a}']:.2f}x) -> {r[f'best@{b}']} (rank "
                  f"{r[f'rank@{b}']}, {r[f'ratio@{b}']:.2f}x, broken {r[f'broken_named@{b}']})")
        rows.append(row)
    return rows


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
