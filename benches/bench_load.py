"""Map loading speed: slamq.load_map against a bare cv2.imread of the same image.

Run: ``PYTHONPATH=python python benches/bench_load.py [MAPS_DIR]`` (default ../shared/data/maps).
Every loadable map is timed (best of 5); the table prints both and their ratio, measured in
the same run.
"""

from __future__ import annotations

import sys
import time
import warnings
from pathlib import Path

import cv2

from slamq.errors import MapError
from slamq.sources import discover_maps, load_map


def best_of(fn, n: int = 5) -> float:
    best = float("inf")
    for _ in range(n):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best


def main() -> None:
    root = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).resolve().parents[2] / \
        "shared" / "data" / "maps"
    warnings.simplefilter("ignore")
    maps, _ = discover_maps([root])
    rows = []
    for p in maps:
        try:
            m = load_map(p)
        except MapError:
            continue
        image = m.meta["image"] or str(p)
        t_load = best_of(lambda p=p: load_map(p))
        t_cv = best_of(lambda image=image: cv2.imread(image, cv2.IMREAD_UNCHANGED))
        rows.append((p.relative_to(root).as_posix(), m.values.size, t_load, t_cv))
    rows.sort(key=lambda r: -r[1])
    print(f"{'map':60s} {'Mcells':>7s} {'load_map ms':>12s} {'imread ms':>10s} {'ratio':>6s}")
    for name, cells, a, b in rows[:10]:
        print(f"{name[:60]:60s} {cells / 1e6:7.2f} {a * 1e3:12.2f} {b * 1e3:10.2f} {a / b:6.2f}")
    tot_a = sum(r[2] for r in rows)
    tot_b = sum(r[3] for r in rows)
    cells = sum(r[1] for r in rows)
    print(f"{'ALL (' + str(len(rows)) + ' maps)':60s} {cells / 1e6:7.2f} {tot_a * 1e3:12.2f} "
          f"{tot_b * 1e3:10.2f} {tot_a / tot_b:6.2f}")
    print(f"load_map throughput: {cells / tot_a / 1e6:.0f} Mcells/s, "
          f"{len(rows) / tot_a:.0f} maps/s")


if __name__ == "__main__":
    main()
