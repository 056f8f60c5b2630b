"""Benchmark: ``slamq.register_many`` (the global registration, docs/spec.md section 7a) on
real folders of maps of one place, one thread.

For each folder (../shared/data/maps, or ``SLAMQ_SHARED_DATA``): every pair (n (n - 1) / 2
registrations, each map prepared once), CPU time of ``slamq.register_many(maps,
threads=1)`` (maps already in memory); then prints, per folder, the time, and per pair the
registration's ok / confidence / inliers and the rotation found.

The rotation search ``align="search"`` used before the global registration is no longer
part of slamq; its figures against this one are in benches/RESULTS.md.

Usage::

    PYTHONPATH=python python benches/bench_register.py [--repeat 3] [--folders awabot,tfm]
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import math  # noqa: E402
import platform  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import slamq  # noqa: E402

ROOT = Path(os.environ.get("SLAMQ_SHARED_DATA",
                           Path(__file__).resolve().parents[2] / "shared" / "data")) / "maps"

FOLDERS = {
    "awabot": ("awabot_trajectoire4_4", [
        "trajectoire4_4_cartographer_1.yaml", "trajectoire4_4_gmapping.yaml",
        "trajectoire4_4_hector_odom.yaml", "trajectoire4_4_rtabmap.yaml"]),
    "tfm": ("tfm_turtlebot4/maps", [
        "cartographer/default.yaml", "cartographer/no_imu.yaml", "gmapping/default.yaml",
        "hector/hector.yaml", "slam_toolbox/HuberLoss.yaml", "slam_toolbox/default.yaml"]),
    "lfz": ("lfz1994_robot_navigation", ["cartographer.yaml", "gmapping.yaml", "karto.yaml"]),
}


def _cpu(fn, repeat: int) -> tuple[float, object]:
    """The smallest CPU time of ``repeat`` calls, and the last result."""
    best, out = math.inf, None
    for _ in range(repeat):
        t = time.process_time()
        out = fn()
        best = min(best, time.process_time() - t)
    return best, out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--folders", default=",".join(FOLDERS))
    args = ap.parse_args()
    print(f"# slamq {slamq.__version__}, {platform.processor() or platform.machine()}, "
          f"load {os.getloadavg()[0]:.1f}; CPU seconds, one thread, best of {args.repeat}")
    rows = []
    for key in args.folders.split(","):
        folder, files = FOLDERS[key]
        maps = {f.removesuffix(".yaml"): slamq.load_map(ROOT / folder / f) for f in files}
        cells = max(m.values.size for m in maps.values())
        t_new, regs = _cpu(lambda m=maps: slamq.register_many(m, threads=1), args.repeat)
        pairs = len(regs)
        rows.append((key, len(maps), pairs, cells, t_new))
        print(f"\n## {folder}: {len(maps)} maps, {pairs} pairs, largest {cells / 1e6:.2f} Mcells")
        print(f"{'moving -> fixed':58s} {'ok':>5s} {'conf':>5s} {'inl':>5s} {'deg':>8s}")
        for (m, f), r in regs.items():
            print(f"{m + ' -> ' + f:58s} {r.ok!s:>5s} {r.confidence:5.2f} {r.inliers:5.2f} "
                  f"{math.degrees(r.theta):8.1f}")
    print(f"\n{'folder':8s} {'maps':>4s} {'pairs':>5s} {'Mcells':>6s} {'s':>7s}")
    for key, n, pairs, cells, t_new in rows:
        print(f"{key:8s} {n:4d} {pairs:5d} {cells / 1e6:6.2f} {t_new:7.2f}")
    print(f"# load {os.getloadavg()[0]:.1f} at the end")


if __name__ == "__main__":
    main()
