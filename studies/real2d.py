"""The real-robot benchmark of issue 40 (examples/real2d.yaml, docs/real-datasets.md).

``python studies/real2d.py prepare OUTPUT``: convert the four CARMEN logs of
``../shared/data/datasets2d/`` into MRPT rawlogs that keep the logs' timestamps
(:func:`slamq.synth.writers.carmen_rawlog.carmen_to_rawlog`) under
``OUTPUT/sequences/NAME/``, with the node-time sidecars of graphslam-engine for each node
spacing of the config (``NAME.rawlog.nodes-<m>m.txt``); a rawlog that exists is kept.

``python studies/real2d.py score OUTPUT``: the relations error (Kümmerle et al. 2009;
:func:`slamq.relations`, interpolated, ``--max-gap`` 60 s) of every run of
``slamq run examples/real2d.yaml``, read from each run's own output files (the poses sorted
by time: the Intel log's stamps run backwards 631 times, as in the original), written to
``OUTPUT/relations.csv`` and printed as the Markdown tables of docs/real-datasets.md.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
from pathlib import Path

import numpy as np

import slamq
from slamq.models import Trajectory
from slamq.sources.carmen import CarmenLog
from slamq.synth.writers.carmen_rawlog import carmen_to_rawlog
from slamq.synth.writers.rawlog import graphslam_nodes

DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "datasets2d"
LOGS = {"intel": "intel/intel.from-rosbag.clf", "aces": "aces/aces.from-rosbag.clf",
        "fr079": "fr079/fr079.from-rosbag.clf", "mit-csail": "mit-csail/mit-csail.clf"}
SPACINGS = (0.5, 1.0)
#: Largest time between two poses a relation stamp is interpolated between: only
#: graphslam-engine's node poses need it (between two nodes the odometry moved less than
#: the node spacing, however long the robot stood).
MAX_GAP = 60.0
STATS = ("n", "n_unplaced", "n_interpolated", "trans_abs_mean", "trans_abs_std",
         "trans_sq_mean", "trans_sq_std", "trans_max", "rot_abs_mean", "rot_abs_std",
         "rot_sq_mean", "rot_sq_std", "rot_max")


def prepare(output: Path, data: Path) -> None:
    for name, log in LOGS.items():
        rawlog = output / "sequences" / name / f"{name}.rawlog"
        if not rawlog.exists():
            info = carmen_to_rawlog(data / log, rawlog)
            print(f"{name}: {info['scans']} scans -> {rawlog}")
        odom = np.array([s.odom for s in CarmenLog(data / log).scans()], np.float64)
        stamps = np.loadtxt(f"{rawlog}.steps.txt", ndmin=1)
        for m in SPACINGS:
            nodes = graphslam_nodes(odom, m, math.radians(30.0))
            np.savetxt(f"{rawlog}.nodes-{m}m.txt", stamps[nodes], fmt="%.6f")


def estimate(folder: Path, run: dict, output: Path) -> Trajectory:
    """A run's poses on the log's clock, sorted by time."""
    out, seq = folder / "out", run["sequence"]
    rawlog = output / "sequences" / seq / f"{seq}.rawlog"
    if run["program"] == "rbpf-slam":
        a = np.loadtxt(out / "log_estimated_path.txt", comments=("%", "#"), ndmin=2)
        t, x, y, yaw = a[:, 7], a[:, 1], a[:, 2], a[:, 4]
    elif run["program"] == "icp-slam":
        a = np.loadtxt(out / "log_estimated_path.txt", comments=("%", "#"), ndmin=2)
        steps = np.loadtxt(f"{rawlog}.steps.txt", ndmin=1)
        t, x, y, yaw = steps[a[:, 0].astype(int)], a[:, 1], a[:, 2], a[:, 3]
    else:
        with open(out / "graphslam" / "output_graph.graph") as f:
            g = np.array([[float(v) for v in line.split()[1:5]] for line in f
                          if line.startswith("VERTEX")])
        g = g[np.argsort(g[:, 0])]
        nodes = np.loadtxt(f"{rawlog}.nodes-{run['params']['spacing']}m.txt", ndmin=1)
        g = g[g[:, 0] < len(nodes)]
        t, x, y, yaw = nodes[g[:, 0].astype(int)], g[:, 1], g[:, 2], g[:, 3]
    o = np.argsort(t, kind="stable")
    return Trajectory.from_xy_yaw(t[o], x[o], y[o], yaw[o], source=str(folder))


def score(output: Path, data: Path) -> list[dict]:
    rels = {d: slamq.load_relations(data / d / f"{d}.relations") for d in LOGS}
    rows = []
    for rj in sorted(output.glob("*/*/*/*/run.json")):
        run = json.loads(rj.read_text())
        row = {k: run.get(k) for k in ("algorithm", "program", "variant", "sequence",
                                      "iteration", "wall", "max_rss_kb")}
        row["cpu"] = (run.get("user_cpu") or 0.0) + (run.get("sys_cpu") or 0.0)
        try:
            res = slamq.relations(estimate(rj.parent, run, output), rels[run["sequence"]],
                                  interpolate=True, max_gap=MAX_GAP)
            row.update({s: getattr(res, s) for s in STATS})
        except (OSError, ValueError, IndexError, slamq.SlamqError) as exc:
            row["error"] = str(exc)[:200]
        rows.append(row)
    keys = list(dict.fromkeys(k for r in rows for k in r))
    with open(output / "relations.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)
    return rows


def markdown(rows: list[dict]) -> str:
    import pandas as pd

    d = pd.DataFrame(rows)
    out = []
    for seq, b in d.groupby("sequence"):
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
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("step", choices=("prepare", "score"))
    p.add_argument("output", type=Path)
    p.add_argument("--data", type=Path, default=DATA)
    a = p.parse_args(argv)
    if a.step == "prepare":
        prepare(a.output, a.data)
    else:
        sys.stdout.write(markdown(score(a.output, a.data)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
