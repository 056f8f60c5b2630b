"""The real-robot benchmark of issue 40 (examples/real2d.yaml, docs/real-datasets.md): its
tables, from the output folder of ``slamq run examples/real2d.yaml``.

``slamq run`` does the benchmark itself: it converts the four CARMEN logs of
``../shared/data/datasets2d/`` (``carmen:`` sequences, the logs' own timestamps), runs MRPT's
three programs and scores every run by the relations error of Kümmerle et al. 2009
(``relations:``; the ``rel_*`` columns of ``OUTPUT/results.jsonl``, docs/spec.md 6a).
``python studies/real2d.py OUTPUT`` joins those columns with each run's CPU time and peak
memory (``OUTPUT/runs.csv``), writes ``OUTPUT/relations.csv`` (one row per run) and prints
the Markdown tables of docs/real-datasets.md (per dataset and program variant: the mean over
the iterations of each statistic, the spread of the mean absolute translational error over
the iterations, CPU seconds per run).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import pandas as pd

#: The relations statistics (``rel_<name>`` in results.jsonl), as relations.csv names them.
STATS = ("n", "n_unplaced", "n_interpolated", "trans_abs_mean", "trans_abs_std",
         "trans_sq_mean", "trans_sq_std", "trans_max", "rot_abs_mean", "rot_abs_std",
         "rot_sq_mean", "rot_sq_std", "rot_max")


def table(output: Path) -> pd.DataFrame:
    """One row per run: where it belongs, its CPU time and memory, its relations error
    (``error`` when it has none: the run failed, or its trajectory could not be scored).

    Examples
    --------
    >>> import json, tempfile
    >>> d = Path(tempfile.mkdtemp())
    >>> _ = (d / "runs.csv").write_text("algorithm,program,variant,sequence,iteration,wall,"
    ...     "user_cpu,sys_cpu,max_rss_kb,outcome\\nicp-slam[grid=1],icp-slam,grid=1,aces,1,"
    ...     "9.5,3.0,0.5,81000,ok\\n")
    >>> rec = {"algorithm": "icp-slam[grid=1]", "sequence": "aces", "run": "1",
    ...        "map": "m.yaml", "rel_trans_abs_mean": 0.8, "rel_error": None}
    >>> _ = (d / "results.jsonl").write_text(json.dumps(rec) + "\\n")
    >>> row = table(d).iloc[0]
    >>> row["program"], float(row["cpu"]), float(row["trans_abs_mean"])
    ('icp-slam', 3.5, 0.8)
    """
    from slamq.results.formats import read_records

    runs = pd.read_csv(output / "runs.csv", dtype={"iteration": str})
    runs["cpu"] = runs["user_cpu"].fillna(0.0) + runs["sys_cpu"].fillna(0.0)
    keep = [c for c in ("algorithm", "program", "variant", "sequence", "iteration", "wall",
                        "max_rss_kb", "cpu", "outcome", "reason") if c in runs.columns]
    runs = runs[keep]
    recs = pd.DataFrame(read_records(output / "results.jsonl"))
    recs = recs.rename(columns={"run": "iteration", **{f"rel_{s}": s for s in STATS}})
    recs["iteration"] = recs["iteration"].astype(str)
    for s in STATS:  # None in a failed run's record makes the column an object column
        if s in recs:
            recs[s] = pd.to_numeric(recs[s], errors="coerce")
    cols = ["algorithm", "sequence", "iteration", "map", *[s for s in STATS if s in recs],
            *[c for c in ("rel_error", "error") if c in recs]]
    out = runs.merge(recs[cols], on=["algorithm", "sequence", "iteration"], how="left")
    return out.sort_values(["sequence", "algorithm", "iteration"], kind="stable")


def markdown(rows: pd.DataFrame) -> str:
    """The per-dataset tables of docs/real-datasets.md."""
    out = []
    for seq, b in rows.groupby("sequence"):
        out += [f"\n#### {seq}\n", "| program [variant] | abs trans (m) | sq trans (m²) | "
                "abs rot (deg) | sq rot (deg²) | max trans (m) | std of abs trans over seeds "
                "| CPU s / run |", "|---|---|---|---|---|---|---|---|"]
        for a, r in b.groupby("algorithm"):
            m = r.mean(numeric_only=True)
            out.append(f"| {a} | {m.trans_abs_mean:.3f} ± {m.trans_abs_std:.3f} | "
                       f"{m.trans_sq_mean:.3f} ± {m.trans_sq_std:.3f} | "
                       f"{m.rot_abs_mean:.2f} ± {m.rot_abs_std:.2f} | "
                       f"{m.rot_sq_mean:.1f} ± {m.rot_sq_std:.1f} | {m.trans_max:.2f} | "
                       f"{r.trans_abs_mean.std():.3f} | {m.cpu:.1f} |")
    return "\n".join(out) + "\n"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    p.add_argument("output", type=Path,
                   help="the output folder of slamq run examples/real2d.yaml")
    a = p.parse_args(argv)
    rows = table(a.output)
    rows.to_csv(a.output / "relations.csv", index=False)
    sys.stdout.write(markdown(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
