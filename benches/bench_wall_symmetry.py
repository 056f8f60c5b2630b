"""Benchmark: what the wall-symmetry sums (spec section 3a.2: the sixth harmonic and the
weight beside the fourth) add to the default evaluation.

For each real map of ../shared/data that ``bench_canonical.py`` times (skipped when
absent), one thread, map in memory, minimum of ``--repeat`` runs, the two cores taking
turns within each repeat:

- ``before``: the core given by ``--baseline`` (a ``_core`` extension built before the
  change, e.g. main's), ``evaluate`` with ``sweep_step=256`` (occupancy, corners, one
  binarisation of the sweep, the wall angle: the fourth harmonic alone);
- ``after``: this checkout's core, the same call (the wall pass now sums five terms);
- ``wall pass``: this checkout's ``wall_harmonics`` alone (the blur, Sobel and the five
  sums).

Usage::

    PYTHONPATH=python python benches/bench_wall_symmetry.py --baseline OLD/_core.abi3.so \
        [--repeat 7] [--cpu]
"""

from __future__ import annotations

import argparse
import importlib.machinery
import importlib.util
import os
import platform
import sys
import time
import warnings
from pathlib import Path
from types import ModuleType

import numpy as np
from bench_canonical import MAPS

import slamq
from slamq import native


def load_core(path: Path) -> ModuleType:
    """An extension ``_core`` from ``path``, as its own module (not ``slamq._core``)."""
    loader = importlib.machinery.ExtensionFileLoader("walls_baseline._core", str(path))
    spec = importlib.util.spec_from_file_location("walls_baseline._core", str(path),
                                                  loader=loader)
    if spec is None:
        raise SystemExit(f"{path}: not an extension module")
    module = importlib.util.module_from_spec(spec)
    loader.exec_module(module)
    return module


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--baseline", type=Path, required=True,
                    help="a _core extension built before the change")
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--cpu", action="store_true",
                    help="CPU seconds of the process instead of wall-clock (a loaded machine)")
    ap.add_argument("--data", type=Path,
                    default=Path(__file__).resolve().parent.parent.parent / "shared" / "data")
    args = ap.parse_args()
    clock = time.process_time if args.cpu else time.perf_counter
    old = load_core(args.baseline)
    params = slamq.Params(sweep_step=256)
    print(f"- machine: {platform.machine()}, Python {platform.python_version()}; one thread; "
          f"minimum of {args.repeat} runs, the cores taking turns; "
          f"{'CPU' if args.cpu else 'wall-clock'} time; load average "
          f"{' '.join(f'{x:.1f}' for x in os.getloadavg())}")
    print()
    print("| map | Mcells | class | before ms | after ms | after / before | wall pass ms "
          "| wall pass / after |")
    print("|---|---:|---|---:|---:|---:|---:|---:|")
    ratios = []
    for name in MAPS:
        path = args.data / "maps" / name
        if not path.exists():
            print(f"| {name} | skipped: not found | | | | | | |")
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            m = slamq.load_map(path)
        v, u, res = np.ascontiguousarray(m.values), np.ascontiguousarray(m.unknown), \
            m.resolution
        if old.evaluate(v, u, params, 1, res).wall_angle != \
                native.evaluate(v, u, params, 1, res).wall_angle:
            raise SystemExit(f"{name}: the two cores' wall angles differ")
        times: dict[str, list[float]] = {"before": [], "after": [], "pass": []}
        calls = (("before", old.evaluate, (v, u, params, 1, res)),
                 ("after", native.evaluate, (v, u, params, 1, res)),
                 ("pass", native.wall_harmonics, (v, u, 1)))
        for _ in range(args.repeat):
            for key, fn, call_args in calls:
                t = clock()
                fn(*call_args)
                times[key].append(clock() - t)
        before, after, wall = (min(times[k]) for k in ("before", "after", "pass"))
        ratios.append(after / before)
        q = slamq.evaluate(m, sweep_step=256)
        print(f"| {name} | {m.values.size / 1e6:.2f} | {q.wall_symmetry} | "
              f"{before * 1e3:.1f} | {after * 1e3:.1f} | {after / before:.3f} | "
              f"{wall * 1e3:.1f} | {wall / after:.2f} |")
    if ratios:
        print(f"\nafter / before: median {sorted(ratios)[len(ratios) // 2]:.3f}, "
              f"worst {max(ratios):.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
