"""Benchmark: a trajectory against its own scans, split in time (docs/spec.md 7e,
:func:`slamq.scan_split`): the Rust core against its numpy twin and against the OpenCV
prototype of ``studies/split_scans.py``, measured in one run.

Recordings: the Intel Research Lab's CARMEN log of ../shared/data/datasets2d (13631 scans x
180 beams) at its raw odometry (a drifting path; skipped when the corpus is absent), and a
simulated office drive (``--length`` metres, 361 beams) at its exact path. For each: the
core at its defaults with 1 and 2 threads, the OpenCV prototype at the same defaults, and
the core and the numpy twin with ``--draw`` scans drawn and half as many tested a half (the
twin walks every beam in Python, so it is timed on a few). Best of ``--repeat``; the
figures and ratios are printed with the times. Then a large building: the office drive with
every other scan moved ``--apart`` metres along both axes (one grid over both places, more
than 2^24 cells, where the halves are drawn one after the other), timed beside the drive
itself, with the peak memory of a process that splits it once.

Usage::

    PYTHONPATH=python python benches/bench_split.py [--repeat 3] [--draw 60] [--length 150]
        [--apart 250]
"""

from __future__ import annotations

import argparse
import platform
import sys
import time
from pathlib import Path
from typing import Any, Callable

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # studies/


def best(f: Callable[[], Any], repeat: int) -> tuple[float, Any]:
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = f()
        times.append(time.perf_counter() - t0)
    return min(times), out


def intel() -> tuple[Any, Any] | None:
    import numpy as np

    from slamq import Trajectory, load_scans
    from slamq.sources.carmen import CarmenLog

    log = ROOT.parent / "shared" / "data" / "datasets2d" / "intel" / "intel.from-rosbag.clf"
    if not log.is_file():
        return None
    t, x, y, yaw = np.array(sorted((s.stamp, *s.odom) for s in CarmenLog(log).scans())).T
    return load_scans(log), Trajectory.from_xy_yaw(t, x, y, yaw)


def simulated(length: float) -> tuple[Any, Any]:
    from slamq.models import Scans, Trajectory
    from slamq.synth import LaserSpec, simulate, world

    seq = simulate(world(5, kind="office", size=(30.0, 20.0)), seed=3, noise="high",
                   laser=LaserSpec(beams=361), length=length)
    return Scans.from_sequence(seq), Trajectory.from_xy_yaw(seq.stamps, *seq.gt.T)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--draw", type=int, default=60)
    ap.add_argument("--length", type=float, default=150.0)
    ap.add_argument("--apart", type=float, default=250.0)
    a = ap.parse_args()
    cases = [("intel, odometry", intel()), ("office drive, exact path",
                                             simulated(a.length))]
    print(f"# {platform.machine()}, {len(__import__('os').sched_getaffinity(0))} cores; "
          f"best of {a.repeat}")
    print(f"{'recording':26s} {'what':34s} {'seconds':>8s} {'figure':>8s} {'ratio':>8s}")
    for name, case in cases:
        if case is None:
            print(f"{name:26s} skipped: ../shared/data/datasets2d not found")
            continue
        measure(f"{name} ({len(case[0])}x{case[0].angles.size})", *case, a)
    large(*cases[1][1], a)  # type: ignore[misc]


def measure(label: str, scans: Any, traj: Any, a: argparse.Namespace) -> None:
    """One recording's rows of the table."""
    from slamq import scan_split
    from slamq.metrics.split import scan_split_reference
    from studies.split_scans import split_crossing

    one, s1 = best(lambda: scan_split(scans, traj, threads=1), a.repeat)
    two, s2 = best(lambda: scan_split(scans, traj, threads=2), a.repeat)
    proto, p = best(lambda: split_crossing(scans, traj), a.repeat)
    small = {"max_draw": a.draw, "max_test": max(a.draw // 2, 1)}
    core, c = best(lambda: scan_split(scans, traj, threads=1, **small), a.repeat)
    ref, r = best(lambda: scan_split_reference(scans, traj, **small), 1)
    same = all((x == y).all() for x, y in zip(c.counts, r.counts))
    rows = [("core, defaults, 1 thread", one, s1.crossing_share, 1.0),
            ("core, defaults, 2 threads", two, s2.crossing_share, one / two),
            ("OpenCV prototype, defaults", proto, p["split_crossing"], proto / one),
            (f"core, {a.draw} drawn, 1 thread", core, c.crossing_share, 1.0),
            (f"numpy twin, {a.draw} drawn", ref, r.crossing_share, ref / core)]
    for what, sec, fig, ratio in rows:
        print(f"{label:26s} {what:34s} {sec:8.3f} {100 * fig:7.2f}% {ratio:7.1f}x")
    print(f"{label:26s} the twin's counts equal the core's: {same}")


def _two_places(traj: Any, apart: float) -> Any:
    """The drive's poses at its own stamps, every other one moved ``apart`` metres."""
    import numpy as np

    poses = np.column_stack([traj.positions[:, :2], traj.yaw])
    poses[1::2, :2] += apart
    return poses


def _peak(apart: float, length: float) -> tuple[float, float, int]:
    """In a fresh interpreter: the drive made, then split once over two places ``apart``
    metres apart; (peak RSS before the split and after it in MiB, cells of one map)."""
    import subprocess

    # VmHWM, not ru_maxrss: Linux keeps the forking parent's ru_maxrss across exec
    code = ("import re, sys; sys.path[:0] = [sys.argv[1], sys.argv[2]]; "
            "import bench_split as b; from slamq import scan_split; "
            "hwm = lambda: re.search(r'VmHWM:\\s+(\\d+)', "
            "open('/proc/self/status').read()).group(1); "
            "s, t = b.simulated(float(sys.argv[4])); r0 = hwm(); "
            "out = scan_split(s, b._two_places(t, float(sys.argv[3])), threads=1); "
            "print(r0, hwm(), out.maps[0].values.size)")
    run = subprocess.run([sys.executable, "-c", code, str(ROOT / "benches"), str(ROOT),
                          str(apart), str(length)], capture_output=True, text=True,
                         check=True)
    r0, r1, cells = run.stdout.split()
    return int(r0) / 1024, int(r1) / 1024, int(cells)


def large(scans: Any, traj: Any, a: argparse.Namespace) -> None:
    """The drive over two places ``a.apart`` metres apart beside the drive itself."""
    from slamq import scan_split

    poses = _two_places(traj, a.apart)
    here = _two_places(traj, 0.0)
    base, b = best(lambda: scan_split(scans, here, threads=1), a.repeat)
    one, s1 = best(lambda: scan_split(scans, poses, threads=1), a.repeat)
    two, s2 = best(lambda: scan_split(scans, poses, threads=2), a.repeat)
    small_before, small_rss, small_cells = _peak(0.0, a.length)
    big_before, big_rss, big_cells = _peak(a.apart, a.length)
    label = f"two places {a.apart:g} m apart"
    rows = [(f"one place ({small_cells / 1e6:.1f} Mcells), 1 thread", base,
             b.crossing_share, 1.0),
            (f"two places ({big_cells / 1e6:.1f} Mcells), 1 thread", one,
             s1.crossing_share, one / base),
            ("two places, 2 threads", two, s2.crossing_share, two / base)]
    for what, sec, fig, ratio in rows:
        print(f"{label:26s} {what:34s} {sec:8.3f} {100 * fig:7.2f}% {ratio:7.1f}x")
    print(f"{label:26s} peak RSS of a process that splits once: {small_rss:.0f} MiB (one "
          f"place), {big_rss:.0f} MiB (two places); before the split {small_before:.0f} "
          f"and {big_before:.0f} MiB")


if __name__ == "__main__":
    main()
