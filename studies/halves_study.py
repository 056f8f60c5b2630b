"""The halves' precision where the maps disagree: the path whose halves cross each other's
walls the least where they meet named (candidate P1, the travel veto after it; P1b,
without; P1c, no travel veto for any named map the halves separate so; P1d, P1c with the
flags of a place drawn twice set aside for its pick), beside the rule as shipped, on
generated sets at rbpf-slam's mean path and at its most likely one (docs/validity.md,
"The halves' precision where the maps disagree", "Exempt from the travel veto where the
halves separate the paths" and "The halves against the flags of a place drawn twice").

Usage (from the repository's root; each set's evidence cached by ``scans_study.py`` and
``rbpf_path_study.py --travel``)::

    PYTHONPATH=studies python studies/halves_study.py studies/scans-benchmark-ai-runs --pairs
    PYTHONPATH=studies python studies/halves_study.py studies/scans-benchmark-ai-runs --premise

Prints, per set and reading, the sequences (and with ``--pairs`` the pairs) in the ATE
top two (the better of two) and the broken runs named under each rule, and every verdict
a candidate changes. On the real logs: ``scans_study.py real ... --halves``.
"""

from __future__ import annotations

import argparse
import copy
from pathlib import Path

import rbpf_path_study as R
import scans_study as S

BEFORE = (*R.RULE, S.HALVES_OFF)  # "shipped" in the tables: the rule before 2026-12-02
P1 = (*R.RULE, S.HALVES)
P1B = (*R.RULE, S.HALVES_ALONE)
P1C = (*R.RULE, S.HALVES_ANY)
P1D = (*R.RULE, S.HALVES_FLAGS)  # shipped since


RULES = {"shipped": BEFORE, "P1": P1, "P1b": P1B, "P1c": P1C, "P1d": P1D}


def premise(out: Path) -> list[dict]:
    """P1d's premise on one set, at both readings: every sequence whose halves set a
    program apart (:func:`slamq.verdict.rule.halves_apart`) while its maps carry a flag of
    a place drawn twice held against it (``S.TWICE``), whatever the verdict: that
    program's ATE against the sequence's best (broken: over 3x and over 0.2 m)."""
    from slamq.verdict.rule import _defects_held, halves_apart

    df, cache, figure, values, _, new_cache, new_values = R.load_set(
        out, (out / "split-v300-rows.csv").exists())
    df_ml = R.most_likely_paths(df, out)
    rows = []
    for reading, d, c, v, truth in (("mean path", df, cache, values, "ate_rmse"),
                                    ("map's path", df_ml, new_cache, new_values, "ate_ml")):
        c = copy.deepcopy(c)
        S.verdicts(d.assign(ate_ml=df_ml["ate_ml"]), truth, rules=(P1C,), cache=c,
                   figure=figure, values=v)
        ok = d.assign(ate_ml=df_ml["ate_ml"])
        for (label, _maps), ev in c.items():
            if "#" in label or label not in set(ok["sequence"].astype(str)):
                continue
            info = S.with_split_hits(ev)["algorithms"]
            if len(info) < 3 or (x := halves_apart(info)) is None:
                continue
            kinds = _defects_held(info[x])
            t = ok[ok["sequence"].astype(str) == label].groupby("algorithm")[truth].mean()
            ratio = float(t[x] / t.min())
            rows.append({"set": out.name, "reading": reading, "sequence": label,
                         "apart": x, "twice": ",".join(k for k in kinds if k in S.TWICE),
                         "other flags": ",".join(k for k in kinds if k not in S.TWICE),
                         "rank": int((t < t[x]).sum()) + 1, "ratio": round(ratio, 2),
                         "broken": bool(ratio > 3 and t[x] > 0.2)})
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    ap.add_argument("output", type=Path, nargs="+", help="slamq run outputs of generated sets")
    ap.add_argument("--pairs", action="store_true", help="the two-map cases too")
    ap.add_argument("--premise", action="store_true",
                    help="P1d's premise instead: each sequence whose halves set apart a "
                    "program its flags of a place drawn twice stop, and its ATE")
    a = ap.parse_args(argv)
    if not a.premise:
        R.compare_sets(a.output, RULES, a.pairs)
        return 0
    import pandas as pd

    rows = [r for out in a.output for r in premise(out)]
    table = pd.DataFrame(rows)
    print(table.to_string(index=False) if rows else "no sequence's halves set apart a program")
    if rows:
        t = table[table["twice"] != ""]
        print(f"\nwith a flag of a place drawn twice: {len(t)}; in the ATE top two "
              f"{int((t['rank'] <= 2).sum())}, broken {int(t['broken'].sum())}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
