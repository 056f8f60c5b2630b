"""Benchmark: a map against its own scans (``rust/src/scans.rs``, docs/spec.md 7b).

On a generated office world of about 2 Mcells (100 x 50 m at 0.05 m) and ``--scans`` scans
of ``--beams`` beams over 360 degrees along its planned drive (odometry poses, so that
beams do see through walls), times:

- ``scan_consistency`` with 1 and 2 threads, milliseconds (best of ``--repeat``);
- its numpy twin ``scan_consistency_reference`` on ``--numpy-scans`` scans, scaled to all
  the scans, and the ratio in this run; the two results are checked equal on that subset.

Not a timed test. Target: part of "the verdict of 6 maps of up to 2 Mcells, scans
included, <= 3 s on 2 cores", so about 0.2 s per map.

Usage::

    PYTHONPATH=python python benches/bench_scans.py [--scans 2000] [--beams 360]
        [--repeat 3] [--numpy-scans 50]
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import time

import numpy as np


def best(f, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        f()
        times.append(time.perf_counter() - t)
    return min(times)


def main() -> None:
    from slamq.metrics.scans import scan_consistency, scan_consistency_reference
    from slamq.models import Scans
    from slamq.synth import LaserSpec, simulate, world

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--scans", type=int, default=2000)
    ap.add_argument("--beams", type=int, default=360)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--numpy-scans", type=int, default=50)
    args = ap.parse_args()

    t = time.perf_counter()
    w = world(args.seed, kind="office", size=(100.0, 50.0))
    laser = LaserSpec(beams=args.beams, fov=2 * math.pi * (args.beams - 1) / args.beams)
    # 0.5 m/s at 10 Hz: 0.05 m per scan
    seq = simulate(w, seed=args.seed, noise="low", laser=laser,
                   length=0.05 * args.scans + 5.0)
    n = min(args.scans, len(seq))
    scans = Scans(seq.stamps[:n], laser.angles(), seq.ranges[:n], laser.max_range,
                  min_range=laser.min_range)
    poses = seq.odom[:n]
    print(f"# {platform.processor() or platform.machine()}, {os.cpu_count()} cores; "
          f"map {w.shape[0]} x {w.shape[1]} = {w.values.size / 1e6:.2f} Mcells, {n} scans x "
          f"{args.beams} beams (setup {time.perf_counter() - t:.0f} s)")

    out = {}
    for threads in (1, 2):
        out[threads] = scan_consistency(w, scans, poses, threads=threads)
        s = best(lambda th=threads: scan_consistency(w, scans, poses, threads=th), args.repeat)
        print(f"scan_consistency, {threads} thread(s): {s * 1e3:8.1f} ms "
              f"({n * args.beams / s / 1e6:.1f} M beams/s)")
        out[f"t{threads}"] = s
    assert np.array_equal(out[1].counts, out[2].counts)
    c = out[1]
    print(f"  hit share {c.hit_share:.3f}, violation share {c.violation_share:.3f}, "
          f"violations in {np.count_nonzero(c.violation_grid)} cells")

    k = min(args.numpy_scans, n)
    sub = Scans(scans.stamps[:k], scans.angles, scans.ranges[:k], scans.max_range,
                min_range=scans.min_range)
    t = time.perf_counter()
    ref = scan_consistency_reference(w, sub, poses[:k])
    s_ref = (time.perf_counter() - t) * n / k
    rust = scan_consistency(w, sub, poses[:k], threads=1)
    assert np.array_equal(ref.counts, rust.counts)
    assert np.array_equal(ref.violation_grid, rust.violation_grid)
    print(f"numpy twin ({k} scans, scaled to {n}): {s_ref * 1e3:8.0f} ms; "
          f"ratio to Rust 1 thread {s_ref / out['t1']:.0f}x, 2 threads "
          f"{s_ref / out['t2']:.0f}x")


if __name__ == "__main__":
    main()
