"""Benchmark: the defect detectors of ``slamq.metrics.defects``, CPU time per million cells
on one thread, with ``slamq.evaluate`` (the three map metrics, Rust) timed on the same maps
in the same run as the yardstick.

Maps: a 2-Mcell tiling of the gmapping office map of tests/data (2 x 2 copies side by side,
about 1.4 x 1.4 k cells, mostly known) and, when ../shared/data is there, the largest real
maps (awabot hector_odom 3.6 Mcells at 0.025 m, mu_gm 3.9 Mcells, utexas 2).

Usage::

    PYTHONPATH=python python benches/bench_defects.py [--repeat 3]
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import cv2  # noqa: E402
import numpy as np  # noqa: E402

import slamq  # noqa: E402
from slamq import OccupancyMap  # noqa: E402
from slamq.metrics.defects import DETECTORS  # noqa: E402

cv2.setNumThreads(1)
REPO = Path(__file__).resolve().parent.parent
SHARED = Path(os.environ.get("SLAMQ_SHARED_DATA", REPO.parent / "shared" / "data")) / "maps"
REAL = ["awabot_trajectoire4_4/trajectoire4_4_hector_odom.yaml",
        "base_model_mu_building/mu_gm.yaml", "utexas_gdc_large/2/2.yaml"]


def _cpu(fn, repeat: int) -> float:
    best = float("inf")
    for _ in range(repeat):
        t = time.process_time()
        fn()
        best = min(best, time.process_time() - t)
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    office = slamq.load_map(REPO / "tests/data/slam_comparison_tools/test_results/office/"
                            "gmapping_map.yaml")
    tiled = OccupancyMap(np.tile(office.values, (2, 2)), np.tile(office.unknown, (2, 2)),
                         office.resolution, office.origin, source="office gmapping x4")
    maps = [tiled] + [slamq.load_map(SHARED / p) for p in REAL if (SHARED / p).exists()]
    print(f"load: {os.getloadavg()[0]:.2f} (1 min); CPU seconds, best of {args.repeat}")
    head = "| map | Mcells | evaluate | " + " | ".join(DETECTORS) + " |"
    print(head)
    print("|---|---|---|" + "---|" * len(DETECTORS))
    for m in maps:
        mc = m.values.size / 1e6
        ev = _cpu(lambda m=m: slamq.evaluate(m, threads=1), args.repeat)
        cells = [f"{1000 * ev / mc:.0f} ms/Mc"]
        for fn in DETECTORS.values():
            t = _cpu(lambda m=m, fn=fn: fn(m), args.repeat)
            cells.append(f"{1000 * t / mc:.0f} ms/Mc ({t / ev:.1f}x)")
        print(f"| {Path(m.source).name} | {mc:.2f} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
