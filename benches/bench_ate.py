"""Benchmark: ATE with alignment on a million poses, slamq vs evo, same files, same run.

Synthesises a ground-truth TUM file and an estimate (the ground truth moved by a rigid
motion, with noise and timestamp jitter) in a temporary folder, then times, with the
file reading included:

- slamq: ``load_trajectory`` x 2 + ``ate(align="se3")`` (and ``align="se2"``),
- evo's Python API: ``file_interface.read_tum_trajectory_file`` x 2 +
  ``sync.associate_trajectories`` + ``main_ape.ape(align=True)``,
- optionally the ``evo_ape tum GT EST -a`` command (``--cli``; includes start-up),

then the peak memory of each side, each in a fresh process (``--no-memory`` skips it),

asserts that the RMSE (and every statistic) agree to 1e-9 with evo's, and (se3 and se2)
with slamq's numpy reference ``ate_numpy``, and prints a table with the ratios measured in
this run.

Usage::

    PYTHONPATH=python python benches/bench_ate.py [--n 1000000] [--repeat 3] [--cli]
"""

from __future__ import annotations

import argparse
import copy
import logging
import os
import platform
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

STATS = ("rmse", "mean", "median", "std", "min", "max", "sse")


def synthesize(folder: Path, n: int, seed: int = 0) -> tuple[Path, Path]:
    """Write gt.txt and est.txt (TUM) with ``n`` poses each; returns their paths."""
    rng = np.random.default_rng(seed)
    t = 1.6e9 + np.arange(n) * 0.01
    steps = rng.normal(size=(n, 3)) * [0.01, 0.01, 0.001]
    xyz = np.cumsum(steps, axis=0)
    yaw = np.cumsum(rng.normal(size=n) * 0.005)
    quat = np.zeros((n, 4))  # qx qy qz qw
    quat[:, 2] = np.sin(yaw / 2)
    quat[:, 3] = np.cos(yaw / 2)
    a = 0.7
    r = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])
    est_xyz = (xyz - [3.0, -2.0, 0.0]) @ r + rng.normal(size=(n, 3)) * 0.02
    est_t = t + rng.uniform(-0.002, 0.002, size=n)
    est_quat = np.zeros((n, 4))
    est_quat[:, 2] = np.sin((yaw - a) / 2)
    est_quat[:, 3] = np.cos((yaw - a) / 2)
    gt_path, est_path = folder / "gt.txt", folder / "est.txt"
    fmt = "%.6f %.9f %.9f %.9f %.9f %.9f %.9f %.9f"
    with open(gt_path, "w") as f:
        f.write("# timestamp tx ty tz qx qy qz qw\n")
        np.savetxt(f, np.column_stack([t, xyz, quat]), fmt=fmt)
    with open(est_path, "w") as f:
        np.savetxt(f, np.column_stack([est_t, est_xyz, est_quat]), fmt=fmt)
    return gt_path, est_path


def run_slamq(gt: Path, est: Path, align: str) -> dict:
    from slamq.metrics.ate import ate
    from slamq.sources.trajectories import load_trajectory

    r = ate(load_trajectory(gt), load_trajectory(est), align=align)
    return {k: float(getattr(r, k)) for k in STATS} | {"n": r.n}


def run_slamq_numpy(gt: Path, est: Path, align: str) -> dict:
    """The numpy reference of slamq's ATE (``ate_numpy``) on the same files (not timed)."""
    from slamq.metrics.ate import ate_numpy
    from slamq.sources.trajectories import load_trajectory

    r = ate_numpy(load_trajectory(gt), load_trajectory(est), align=align)
    return {k: float(getattr(r, k)) for k in STATS} | {"n": r.n}


def run_evo(gt: Path, est: Path) -> dict:
    from evo.core import metrics, sync
    from evo.main_ape import ape
    from evo.tools import file_interface

    ref = file_interface.read_tum_trajectory_file(str(gt))
    e = file_interface.read_tum_trajectory_file(str(est))
    ref, e = sync.associate_trajectories(ref, e)
    res = ape(ref, copy.copy(e), metrics.PoseRelation.translation_part, align=True)
    return {k: float(res.stats[k]) for k in STATS} | {"n": len(res.np_arrays["error_array"])}


def run_evo_cli(gt: Path, est: Path) -> dict:
    exe = shutil.which("evo_ape")
    if exe is None:
        raise RuntimeError("evo_ape not on PATH")
    out = subprocess.run([exe, "tum", str(gt), str(est), "-a"], capture_output=True,
                         text=True, check=True).stdout
    stats = {}
    for k in STATS:
        m = re.search(rf"^\s*{k}\s+([-+0-9.eE]+)\s*$", out, re.M)
        stats[k] = float(m.group(1)) if m else float("nan")
    return stats


def timed(fn, repeat: int, children: bool = False):
    """Best wall-clock and best CPU seconds over ``repeat`` calls, and the last result.

    CPU time (this process, or its children for a command) is reported beside wall time
    because the machine may be shared: it is much less sensitive to other load.
    """
    import resource

    who = resource.RUSAGE_CHILDREN if children else resource.RUSAGE_SELF
    best, best_cpu, out = float("inf"), float("inf"), None
    for _ in range(repeat):
        r0 = resource.getrusage(who)
        t0 = time.perf_counter()
        out = fn()
        wall = time.perf_counter() - t0
        r1 = resource.getrusage(who)
        cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
        best, best_cpu = min(best, wall), min(best_cpu, cpu)
    return best, best_cpu, out


def _status_kb(field: str) -> int:
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(field + ":"):
                return int(line.split()[1])
    return 0


def child(which: str, gt: Path, est: Path) -> None:
    """Run one side once in this (fresh) process and print its peak memory: VmHWM (peak
    resident set) and VmRSS after the imports (the interpreter, numpy, pandas, evo)."""
    logging.getLogger("evo").setLevel(logging.WARNING)
    if which == "evo":
        from evo.core import metrics, sync  # noqa: F401
        from evo.main_ape import ape  # noqa: F401
        from evo.tools import file_interface  # noqa: F401
    else:
        import slamq.metrics.ate  # noqa: F401
        import slamq.sources.trajectories  # noqa: F401
    import pandas  # noqa: F401
    base = _status_kb("VmRSS")
    run_evo(gt, est) if which == "evo" else run_slamq(gt, est, "se3")
    print(base, _status_kb("VmHWM"))


def peak_memory(which: str, gt: Path, est: Path) -> tuple[float, float]:
    """(peak resident MB, peak MB above the imports) of one fresh run of ``which``."""
    out = subprocess.run([sys.executable, __file__, "--child", which, str(gt), str(est)],
                         capture_output=True, text=True, check=True).stdout.split()
    base, peak = int(out[-2]), int(out[-1])
    return peak / 1024, (peak - base) / 1024


def _merge(a, b):
    return min(a[0], b[0]), min(a[1], b[1]), a[2]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=1_000_000, help="poses per file")
    ap.add_argument("--repeat", type=int, default=3, help="slamq repetitions (best kept)")
    ap.add_argument("--evo-repeat", type=int, default=1, help="evo repetitions")
    ap.add_argument("--cli", action="store_true", help="also time the evo_ape command")
    ap.add_argument("--no-memory", action="store_true",
                    help="skip the peak-memory runs (one fresh process per side)")
    ap.add_argument("--child", nargs=3, metavar=("WHICH", "GT", "EST"),
                    help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        child(args.child[0], Path(args.child[1]), Path(args.child[2]))
        return 0
    logging.getLogger("evo").setLevel(logging.WARNING)
    import evo
    import pandas  # noqa: F401 - imported before timing, like evo

    with tempfile.TemporaryDirectory(prefix="slamq_bench_ate_") as tmp:
        t0 = time.perf_counter()
        gt, est = synthesize(Path(tmp), args.n)
        print(f"synthesised 2 x {args.n} poses in {time.perf_counter() - t0:.1f} s "
              f"({gt.stat().st_size / 1e6:.0f} MB each)")
        for p in (gt, est):  # same page-cache state for everyone
            p.read_bytes()
        run_slamq(gt, est, "se3")  # warm-up (imports, allocator)
        rows = []
        # slamq is timed before and after evo (best kept), so that a burst of load from
        # other processes during one phase does not decide the ratio.
        s3 = timed(lambda: run_slamq(gt, est, "se3"), args.repeat)
        s2 = timed(lambda: run_slamq(gt, est, "se2"), args.repeat)
        t_evo, c_evo, r_evo = timed(lambda: run_evo(gt, est), args.evo_repeat)
        if args.cli:
            t_cli, c_cli, r_cli = timed(lambda: run_evo_cli(gt, est), 1, children=True)
        s3 = _merge(s3, timed(lambda: run_slamq(gt, est, "se3"), args.repeat))
        s2 = _merge(s2, timed(lambda: run_slamq(gt, est, "se2"), args.repeat))
        (t_s3, c_s3, r_s3), (t_s2, c_s2, r_s2) = s3, s2
        for k in STATS:
            tol = 1e-9 * max(1.0, abs(r_evo[k]))
            assert abs(r_s3[k] - r_evo[k]) <= tol, (k, r_s3[k], r_evo[k])
        assert r_s3["n"] == r_evo["n"], (r_s3["n"], r_evo["n"])
        # and equal to the numpy reference implementation (slamq.metrics.ate.ate_numpy),
        # for both alignments
        for align, ours in (("se3", r_s3), ("se2", r_s2)):
            ref = run_slamq_numpy(gt, est, align)
            for k in STATS:
                tol = 1e-9 * max(1.0, abs(ref[k]))
                assert abs(ours[k] - ref[k]) <= tol, (align, k, ours[k], ref[k])
            assert ours["n"] == ref["n"], (align, ours["n"], ref["n"])
        rows.append(("evo Python API (read+assoc+ape -a)", t_evo, c_evo, r_evo["rmse"]))
        if args.cli:
            # evo_ape prints 6 decimals
            assert abs(r_cli["rmse"] - r_s3["rmse"]) <= 1e-6, (r_cli["rmse"], r_s3["rmse"])
            rows.append(("evo_ape tum GT EST -a (command)", t_cli, c_cli, r_cli["rmse"]))
        rows.append(("slamq ate(align='se3')", t_s3, c_s3, r_s3["rmse"]))
        rows.append(("slamq ate(align='se2')", t_s2, c_s2, r_s2["rmse"]))
        print(f"\nATE with alignment, {args.n} poses per file, file reading included; "
              f"{r_s3['n']} associated pairs")
        print(f"python {platform.python_version()}, numpy {np.__version__}, "
              f"evo {evo.__version__}, {platform.machine()}, load average "
              f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs")
        print(f"| {'':36s} | {'wall s':>8s} | {'CPU s':>8s} | {'RMSE (m)':>12s} | "
              f"{'evo API / this (wall)':>21s} | {'(CPU)':>6s} |")
        print(f"|{'-' * 38}|{'-' * 10}|{'-' * 10}|{'-' * 14}|{'-' * 23}|{'-' * 8}|")
        for name, sec, cpu, rmse in rows:
            print(f"| {name:36s} | {sec:8.3f} | {cpu:8.3f} | {rmse:12.9f} | "
                  f"{t_evo / sec:20.1f}x | {c_evo / cpu:5.1f}x |")
        print("slamq se3 statistics equal evo's to 1e-9: yes "
              f"(max |diff| {max(abs(r_s3[k] - r_evo[k]) for k in STATS):.1e}); se3 and se2 "
              "equal the numpy reference (ate_numpy) to 1e-9: yes")
        if not args.no_memory:
            evo_peak, evo_above = peak_memory("evo", gt, est)
            s_peak, s_above = peak_memory("slamq", gt, est)
            print("\npeak memory, one fresh process each (VmHWM; 'above imports': minus the "
                  "resident set after importing numpy, pandas and the library)")
            print("| | peak MB | above imports MB |\n|---|---:|---:|")
            print(f"| evo Python API | {evo_peak:.0f} | {evo_above:.0f} |")
            print(f"| slamq ate(align='se3') | {s_peak:.0f} | {s_above:.0f} |")
            print(f"| evo / slamq | {evo_peak / s_peak:.1f}x | {evo_above / s_above:.1f}x |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
