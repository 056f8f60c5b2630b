"""Benchmark: the simulator's laser (``rust/src/raycast.rs``) and a whole simulated sequence.

On a generated 20 x 15 m world at 0.05 m (kind ``office`` by default) and the poses of its
planned drive, times:

- the Rust ray caster (``slamq.synth.sensors.cast``) with 1 and 2 threads, beams per second
  (best of ``--repeat``), 1081 beams over 270 degrees, 20 m range;
- its numpy twin (``cast_numpy``, the same walk) on a subset of the scans, beams per
  second, and the ratio in this run; the two results are checked equal to 1e-9 m;
- ``slamq.synth.simulate`` for ``--scans`` scans of ``--beams`` beams (drive planning, ray
  casting, range and odometry noise), seconds, with 1 thread and every core.

Usage::

    PYTHONPATH=python python benches/bench_raycast.py [--kind office] [--scans 1000]
        [--beams 1081] [--repeat 5]
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np


def best(f, repeat: int, clock=time.perf_counter) -> float:
    times = []
    for _ in range(repeat):
        t = clock()
        f()
        times.append(clock() - t)
    return min(times)


def main() -> None:
    from slamq.synth import LaserSpec, drive, simulate, world
    from slamq.synth.sensors import cast, cast_numpy

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--kind", default="office")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--scans", type=int, default=1000)
    ap.add_argument("--beams", type=int, default=1081)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--numpy-scans", type=int, default=40)
    args = ap.parse_args()

    w = world(args.seed, kind=args.kind)
    laser = LaserSpec(beams=args.beams)
    d = drive(w, seed=args.seed, laps=4)
    if len(d) < args.scans:
        raise SystemExit(f"the drive has {len(d)} poses, fewer than --scans {args.scans}")
    poses = np.ascontiguousarray(d.poses[:args.scans])
    angles = laser.angles()
    beams = poses.shape[0] * angles.size

    ranges = cast(w, poses, angles, laser.max_range, threads=1)
    finite = np.isfinite(ranges)
    t1 = best(lambda: cast(w, poses, angles, laser.max_range, threads=1), args.repeat)
    t2 = best(lambda: cast(w, poses, angles, laser.max_range, threads=2), args.repeat)
    # CPU time of the 1-thread cast: less sensitive to a busy machine than the wall clock
    cpu1 = best(lambda: cast(w, poses, angles, laser.max_range, threads=1), args.repeat,
                time.process_time)
    sub = poses[:: max(1, len(poses) // args.numpy_scans)][: args.numpy_scans]
    t_np = best(lambda: cast_numpy(w, sub, angles, laser.max_range), 1)
    ref = cast_numpy(w, sub, angles, laser.max_range)
    rust_sub = cast(w, sub, angles, laser.max_range, threads=1)
    same = np.array_equal(np.isinf(ref), np.isinf(rust_sub)) and np.allclose(
        ref[np.isfinite(ref)], rust_sub[np.isfinite(ref)], rtol=0, atol=1e-9)
    np_rate = sub.shape[0] * angles.size / t_np

    # a sequence of exactly --scans scans: simulate the drive cut to that many poses
    cut = type(d)(d.stamps[:args.scans], poses, dict(d.meta))
    t_sim1 = best(lambda: simulate(w, seed=args.seed, laser=laser, path=cut, threads=1),
                  args.repeat)
    t_simall = best(lambda: simulate(w, seed=args.seed, laser=laser, path=cut),
                    args.repeat)
    t_plan = best(lambda: drive(w, seed=args.seed), args.repeat)

    print(f"# slamq ray casting, {platform.processor() or platform.machine()}, "
          f"{os.cpu_count()} cores")
    print(f"world {args.kind} seed {args.seed}: {w.shape[1]} x {w.shape[0]} cells at "
          f"{w.resolution} m; {poses.shape[0]} scans x {angles.size} beams = {beams:,} beams,"
          f" {finite.mean():.1%} with a return, mean range "
          f"{ranges[finite].mean():.2f} m")
    print()
    print("| what | time (s) | beams/s | vs numpy |")
    print("|---|---:|---:|---:|")
    print(f"| Rust, 1 thread | {t1:.3f} | {beams / t1 / 1e6:.2f} M | {beams / t1 / np_rate:.0f}x |")
    print(f"| Rust, 2 threads | {t2:.3f} | {beams / t2 / 1e6:.2f} M | "
          f"{beams / t2 / np_rate:.0f}x |")
    print(f"| numpy twin ({sub.shape[0]} scans) | {t_np:.3f} | {np_rate / 1e6:.3f} M | 1x |")
    print()
    print(f"2 / 1 threads: {t1 / t2:.2f}x; 1 thread by CPU time: {beams / cpu1 / 1e6:.2f} M "
          f"beams per CPU second; load average {os.getloadavg()[0]:.1f}; "
          f"Rust == numpy twin (1e-9 m): {same}")
    print()
    print(f"simulate, {poses.shape[0]} scans x {angles.size} beams (given the drive): "
          f"{t_sim1:.3f} s on 1 thread, {t_simall:.3f} s on every core; planning the drive "
          f"({len(drive(w, seed=args.seed))} poses): {t_plan:.3f} s")


if __name__ == "__main__":
    main()
