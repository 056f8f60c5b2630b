"""Benchmark: writing a simulated sequence in every format of ``slamq.synth.writers``, and
(``--mrpt``) what MRPT's SLAM programs make of a written rawlog.

The sequence comes from the simulator when the package has one (``slamq.synth.simulate``
on its office world, cut to ``--scans``), else from the tests' small world
(tests/synth/_world.py: walls as segments, an exact numpy ray cast, a drive around a
loop). Times are the minimum over ``--repeat`` runs, in
one process, files written to a temporary folder (page cache, not the disk's speed).

``--mrpt`` then writes the rawlog of the same drive with perfect and with noisy
odometry (``--noise``: the tests' world's relative odometry error, default 5% of each
step plus a yaw drift; the simulator's ``high`` preset) and runs rbpf-slam,
icp-slam and graphslam-engine on both through ``slamq run`` (examples/synth_mrpt.yaml),
printing ATE RMSE (se2-aligned, against the exact path) and F1 against the world map.

Usage::

    PYTHONPATH=python python benches/bench_writers.py [--scans 1000] [--beams 1081]
        [--repeat 3] [--mrpt] [--noise 0.05] [--iterations 3]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def make(scans: int, beams: int, noise: float, name: str):
    """A sequence of ``scans`` x ``beams``: the simulator's office world (odometry noise
    preset ``none`` when ``noise`` is 0, else ``high``) when slamq has one, else the
    tests' small world with ``noise`` as its relative odometry error."""
    try:
        from slamq.synth import simulate, world  # the simulator (ground truth on demand)
    except ImportError:
        simulate = None
    if simulate is not None:
        from slamq.synth import LaserSpec, Recording

        s = simulate(world(1, kind="office"), seed=1, noise="none" if noise == 0 else "high",
                     laser=LaserSpec(beams=beams), name=name)
        k = min(scans, len(s))
        return Recording(s.stamps[:k], s.gt[:k], s.odom[:k], s.ranges[:k], s.laser, s.world,
                        name, s.meta)
    sys.path.insert(0, str(ROOT / "tests" / "synth"))
    from _world import make_sequence

    return make_sequence(scans, beams, odom_noise=noise, seed=1, name=name)


def bench_formats(scans: int, beams: int, repeat: int) -> None:
    from slamq.synth.writers import FORMATS, write

    gen = []
    for _ in range(repeat):
        t = time.perf_counter()
        seq = make(scans, beams, 0.05, "bench")
        gen.append(time.perf_counter() - t)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for fmt in FORMATS:
            times = []
            for _ in range(repeat):
                t = time.perf_counter()
                out = write(seq, tmp, [fmt])[fmt]
                times.append(time.perf_counter() - t)
            size = (out.stat().st_size if out.is_file()
                    else sum(p.stat().st_size for p in out.rglob("*") if p.is_file()))
            rows.append((fmt, min(times), size))
    total = sum(r[1] for r in rows)
    print(f"\n{scans} scans x {beams} beams ({scans * beams / 1e6:.2f} M ranges), "
          f"min of {repeat}")
    print("| step | seconds | size |\n|---|---|---|")
    what = ("tests/synth/_world.py" if seq.meta.get("world") == "test room"
            else "slamq.synth.simulate, office world")
    print(f"| generation ({what}) | {min(gen):.3f} | |")
    for fmt, t, size in rows:
        print(f"| write {fmt} | {t:.3f} | {size / 2**20:.1f} MiB |")
    print(f"| write, every format | {total:.3f} | |")
    print(f"| generation + every format | {min(gen) + total:.3f} | |")


def bench_mrpt(scans: int, beams: int, noise: float, iterations: int) -> None:
    import shutil

    import cv2
    import yaml

    from slamq.results import read_results
    from slamq.runner import runner
    from slamq.synth.writers import write, write_groundtruth

    if not all(shutil.which(p) for p in ("rbpf-slam", "icp-slam", "graphslam-engine")):
        print("MRPT programs absent (apt-get install mrpt-apps): --mrpt skipped")
        return
    import slamq
    from slamq.models import Trajectory

    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        odo = {}
        for name, n in (("perfect", 0.0), ("noisy", noise)):
            seq = make(scans, beams, n, name)
            write(seq, d, ["rawlog"])
            write_groundtruth(seq, d / f"{name}_gt.tum")
            gt = Trajectory.from_xy_yaw(seq.stamps, *seq.gt.T)
            odo[name] = slamq.ate(gt, Trajectory.from_xy_yaw(seq.stamps, *seq.odom.T)).rmse
        cv2.imwrite(str(d / "world.png"), seq.world.values)
        (d / "world.yaml").write_text(yaml.safe_dump({
            "image": "world.png", "resolution": seq.world.resolution,
            "origin": list(seq.world.origin), "negate": 0, "occupied_thresh": 0.65,
            "free_thresh": 0.196}))
        cfg = yaml.safe_load((ROOT / "examples" / "synth_mrpt.yaml").read_text())
        cfg.update(output=str(d / "runs"), base_dir=str(d), report=False,
                   iterations=iterations)
        cfg["sequences"] = {n: {"input": f"{n}.rawlog", "groundtruth": f"{n}_gt.tum",
                                "groundtruth_map": "world.yaml"} for n in odo}
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            result = runner.run(cfg)
        walls: dict[tuple[str, str], list[float]] = {}
        for r in result["rows"]:
            walls.setdefault((r["algorithm"], r["sequence"]), []).append(r["wall"])
        recs = read_results(d / "runs" / "results.jsonl")
    print(f"\nMRPT 2.5.8 on a written rawlog ({scans} scans x {beams} beams), {iterations} "
          f"run(s) each, mean (min-max); odometry alone: ATE {odo['perfect']:.3f} m "
          f"(perfect), {odo['noisy']:.3f} m (noise {noise})")
    print("| program | odometry | ATE RMSE m | ATE max m | poses | GT F1 | wall s |")
    print("|---|---|---|---|---|---|---|")

    def cell(v) -> str:
        return f"{v.mean():.3f}" + (f" ({v.min():.3f}-{v.max():.3f})" if len(v) > 1 else "")

    for (algo, name), g in sorted(recs.groupby(["algorithm", "sequence"]),
                                  key=lambda kv: (kv[0][0], kv[0][1] != "perfect")):
        print(f"| {algo} | {name} | {cell(g['ate_rmse'])} | {cell(g['ate_max'])} | "
              f"{int(g['ate_n'].iloc[0])} | {cell(g['gt_f1'])} | "
              f"{np.mean(walls[(algo, name)]):.1f} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scans", type=int, default=1000)
    ap.add_argument("--beams", type=int, default=1081)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--mrpt", action="store_true", help="also run the MRPT SLAM programs")
    ap.add_argument("--noise", type=float, default=0.05)
    ap.add_argument("--iterations", type=int, default=3, help="runs per program (--mrpt)")
    args = ap.parse_args()
    bench_formats(args.scans, args.beams, args.repeat)
    if args.mrpt:
        bench_mrpt(args.scans, args.beams, args.noise, args.iterations)


if __name__ == "__main__":
    main()
