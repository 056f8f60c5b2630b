"""Validity of the map metrics and of the GT-free verdict on the real logs of issue 40
(docs/validity.md, "Real robots"): ``python studies/real2d_validity.py OUTPUT`` after
``slamq run examples/real2d.yaml`` (whose ``OUTPUT/results.jsonl`` holds each run's map and
its relations error, the ``rel_*`` columns).

Every run's map is scored (:func:`slamq.evaluate`, ``canonical_resolution=0.07``); each
metric's concordance with the relations error is measured pooled and per dataset
(:func:`slamq.results.validity.validate`); and ``slamq verdict``'s rule
(:func:`slamq.verdict.maps.maps_verdict`) is run on each dataset's six maps of one
iteration, each map weighed against its own scans when the records name them (``scans``,
``trajectory``: ``slamq run`` fills both), its choice ranked by the relations error.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

from slamq.api import evaluate
from slamq.results.formats import read_records
from slamq.results.validity import validate
from slamq.verdict.maps import maps_verdict

METRICS = ("occupied_fraction", "corners", "corners_canonical", "enclosed_areas", "proportion")


def main(argv: list[str] | None = None) -> int:
    import argparse

    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    ap.add_argument("runs", help="the output folder of slamq run examples/real2d.yaml (its "
                    "results.jsonl)")
    root = Path(ap.parse_args(argv if argv is not None else sys.argv[1:]).runs)
    rows = []
    for r in read_records(root / "results.jsonl"):
        m = Path(str(r.get("map")))
        if m.exists() and pd.notna(r.get("rel_trans_abs_mean")):
            e = evaluate(str(m), canonical_resolution=0.07)
            rows.append({"sequence": r["sequence"], "algorithm": r["algorithm"],
                         "run": r["run"], "map": str(m), "scans": r.get("scans"),
                         "trajectory": r.get("trajectory"),
                         "rel_trans_abs_mean": r["rel_trans_abs_mean"],
                         "rel_rot_abs_mean": r["rel_rot_abs_mean"],
                         **{k: getattr(e, k) for k in METRICS}})
    df = pd.DataFrame(rows)
    df.to_csv(root / "validity-rows.csv", index=False)
    t = validate(df, truths=("rel_trans_abs_mean", "rel_rot_abs_mean"), permutations=1000,
                 metrics=METRICS)
    t.to_csv(root / "validity-table.csv", index=False)
    print(t.round(3).to_string())
    out = []
    for (seq, it), b in df.groupby(["sequence", "run"]):
        recordings = set(b["scans"].dropna().astype(str))
        with_scans = len(recordings) == 1 and b["trajectory"].notna().all()
        v = maps_verdict(list(b["map"]), names=list(b["algorithm"]),
                         scans=recordings.pop() if with_scans else None,
                         trajectories=list(b["trajectory"]) if with_scans else None
                         )["verdict"] or {}
        err = b.set_index("algorithm")["rel_trans_abs_mean"]
        best = v.get("best")
        out.append({"sequence": seq, "iteration": it, "scans": with_scans, "best": best,
                    "confidence": v.get("confidence"),
                    "rank": float(err.rank()[best]) if best in err.index else None,
                    "ratio": float(err[best] / err.min()) if best in err.index else None})
    pd.DataFrame(out).to_csv(root / "verdicts.csv", index=False)
    print(pd.DataFrame(out).to_string())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
