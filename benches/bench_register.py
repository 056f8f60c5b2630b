"""Benchmark: ``slamq.register_many`` (the global registration, docs/spec.md section 7a)
against the rotation search ``align="search"`` used before it, on real folders of maps of
one place, one thread, same maps, same run.

For each folder (../shared/data/maps, or ``SLAMQ_SHARED_DATA``):

- new: ``slamq.register_many(maps, threads=1)``: every pair (n (n - 1) / 2 registrations,
  each map prepared once), CPU time of the call (maps already in memory);
- old: ``slamq.native.legacy_search`` for the same pairs (36 rotations from the centroids,
  a short ICP from each, the full ICP), CPU time;

then prints, per folder, both times and their ratio, and per pair the new registration's
ok / confidence and the rotation each method found (a wrong rotation of the old search
shows as a different angle).

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
from slamq import native  # noqa: E402

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


def _legacy(maps: dict) -> dict:
    names = list(maps)
    out = {}
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            fm, mm = maps[a], maps[b]
            out[b, a] = native.legacy_search(
                mm.values, mm.unknown, (mm.resolution, *mm.origin),
                fm.values, fm.unknown, (fm.resolution, *fm.origin), threads=1)
    return out


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
        t_old, old = _cpu(lambda m=maps: _legacy(m), max(1, args.repeat - 2))
        pairs = len(old)
        rows.append((key, len(maps), pairs, cells, t_new, t_old))
        print(f"\n## {folder}: {len(maps)} maps, {pairs} pairs, largest {cells / 1e6:.2f} Mcells")
        print(f"{'moving -> fixed':58s} {'ok':>5s} {'conf':>5s} {'inl':>5s} "
              f"{'new deg':>8s} {'old deg':>8s}")
        for (m, f), theta in old.items():
            r = regs[m, f]
            print(f"{m + ' -> ' + f:58s} {r.ok!s:>5s} {r.confidence:5.2f} {r.inliers:5.2f} "
                  f"{math.degrees(r.theta):8.1f} {math.degrees(theta[0]):8.1f}")
    print(f"\n{'folder':8s} {'maps':>4s} {'pairs':>5s} {'Mcells':>6s} {'new s':>7s} "
          f"{'old s':>7s} {'old/new':>7s}")
    for key, n, pairs, cells, t_new, t_old in rows:
        print(f"{key:8s} {n:4d} {pairs:5d} {cells / 1e6:6.2f} {t_new:7.2f} {t_old:7.2f} "
              f"{t_old / t_new:7.1f}")
    print(f"# load {os.getloadavg()[0]:.1f} at the end")


if __name__ == "__main__":
    main()
