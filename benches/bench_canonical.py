"""Benchmark: what ``corners_canonical`` (spec section 3a) costs next to ``corners``.

Issue 13 asks that the canonical count stays within 2x the time of ``corners``. For each real
map of ../shared/data named below (skipped when absent) this times, one thread, map in
memory, minimum of ``--repeat`` runs:

- ``plain``: ``slamq.evaluate(m, sweep_step=256)``, the defaults (``corners_canonical`` off,
  the wall angle on): occupancy, the corner count, one binarisation of the sweep (an upper
  bound of the time of corners) and the wall angle;
- ``with canonical``: the same with ``canonical_resolution=0.07`` (the reference resolution);

and prints the canonical count's own time (the difference) and its ratio to ``plain``.

``--dense`` times instead the 1-Mcell dense crops of ``bench.py --dense`` (issue 15) as maps
of 0.05 m, the resolution ``bench_batch.py --dense`` gives them, with the full sweep:
``plain`` is then ``slamq.evaluate(m)``, the defaults as a batch computes them. The defaults
against the three metrics alone (without the wall angle): ``rust/examples/stages``.

Usage::

    PYTHONPATH=python python benches/bench_canonical.py [--repeat 7] [--dense]
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
import warnings
from pathlib import Path

import slamq
from slamq.metrics.reference import canonical_map

MAPS = (
    "base_model_mu_building/mu_gm.yaml",
    "utexas_gdc_large/3/3.yaml",
    "utexas_gdc_large/intel_lab/intel.yaml",
    "awabot_trajectoire4_4/trajectoire4_4_hector_odom.yaml",
    "awabot_trajectoire4_4/trajectoire4_4_cartographer_1.yaml",
    "slam_comparison_tools/test_results/warehouse/cartographer_map.yaml",
    "camel_robot_office/slam_toolbox_map1.yaml",
)


CLOCK = time.perf_counter
#: The reference resolution of SPEC 3a (``canonical_resolution`` is 0, off, by default).
REFERENCE = 0.07
CANON = slamq.Params(canonical_resolution=REFERENCE)


def best(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t = CLOCK()
        fn()
        times.append(CLOCK() - t)
    return min(times)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--dense", action="store_true",
                    help="the dense 1-Mcell crops of bench.py --dense, at 0.05 m")
    ap.add_argument("--cpu", action="store_true",
                    help="time CPU seconds of the process (time.process_time) instead of "
                         "wall-clock: on a loaded machine")
    ap.add_argument("--data", type=Path,
                    default=Path(__file__).resolve().parent.parent.parent / "shared" / "data")
    args = ap.parse_args()
    global CLOCK
    if args.cpu:
        CLOCK = time.process_time
    print(f"- machine: {platform.machine()}, Python {platform.python_version()}; one thread; "
          f"minimum of {args.repeat} runs; {'CPU' if args.cpu else 'wall-clock'} time; "
          f"load average {' '.join(f'{x:.1f}' for x in os.getloadavg())}")
    print()
    if args.dense:
        return dense(args.repeat)
    print("| map | Mcells | canonical Mcells | wall angle | plain ms | with canonical ms "
          "| canonical step ms | step / plain |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    ratios = []
    for name in MAPS:
        path = args.data / "maps" / name
        if not path.exists():
            print(f"| {name} | skipped: not found under {args.data} | | | | | | |")
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            m = slamq.load_map(path)
        canon = canonical_map(m, CANON)
        plain = best(lambda m=m: slamq.evaluate(m, threads=1, sweep_step=256), args.repeat)
        full = best(lambda m=m: slamq.evaluate(m, threads=1, sweep_step=256,
                                                canonical_resolution=REFERENCE), args.repeat)
        q = slamq.evaluate(m, sweep_step=256)
        step = max(full - plain, 0.0)
        ratios.append(step / plain)
        print(f"| {name} | {m.values.size / 1e6:.2f} | "
              f"{0 if canon is None else canon.values.size / 1e6:.2f} | {q.wall_angle:+.1f} | "
              f"{plain * 1e3:.1f} | {full * 1e3:.1f} | {step * 1e3:.1f} | "
              f"{step / plain:.2f} |")
    if ratios:
        print(f"\ncanonical step / plain: median {sorted(ratios)[len(ratios) // 2]:.2f}, "
              f"worst {max(ratios):.2f}")
    return 0


def dense(repeat: int) -> int:
    """The canonical step's time on the dense crops of ``bench.py --dense`` (0.05 m)."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from bench import dense_maps

    print("| dense crop (0.05 m) | canonical Mcells | wall angle | defaults ms "
          "| with canonical ms | canonical count ms | with canonical / defaults |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    per_mcell, ratios = [], []
    for label, crop in dense_maps():
        if crop.shape != (1000, 1000):
            continue  # the whole graded maps of bench.py --dense
        m = slamq.OccupancyMap(crop.values, crop.unknown, resolution=0.05)
        canon = canonical_map(m, CANON)
        plain = best(lambda m=m: slamq.evaluate(m, threads=1), repeat)
        full = best(lambda m=m: slamq.evaluate(m, threads=1, canonical_resolution=REFERENCE),
                    repeat)
        q = slamq.evaluate(m)
        per_mcell.append(plain * 1e3 / (m.values.size / 1e6))
        ratios.append(full / plain)
        print(f"| {label} | {0 if canon is None else canon.values.size / 1e6:.2f} | "
              f"{q.wall_angle:+.1f} | {plain * 1e3:.2f} | {full * 1e3:.2f} | "
              f"{max(full - plain, 0.0) * 1e3:.2f} | {full / plain:.2f} |")
    if per_mcell:
        print(f"\ndefaults: mean {sum(per_mcell) / len(per_mcell):.2f} ms/Mcell, worst "
              f"{max(per_mcell):.2f}; with canonical / defaults: mean "
              f"{sum(ratios) / len(ratios):.2f}, worst {max(ratios):.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
