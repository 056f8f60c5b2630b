"""Benchmark: the verdict of 6 maps of about 2 Mcells with their scans (issue 41: "<= 3 s on
2 cores"; docs/spec.md section 9, "Against its own scans").

A generated office world of about 2 Mcells (100 x 50 m at 0.05 m), a drive of ``--scans``
scans of ``--beams`` beams written as an MRPT rawlog with its exact path; six maps of the
world (the walls the laser saw, and five damaged copies: specks twice, drift, doubling,
kinks), each record naming the rawlog (``scans``) and the path (``trajectory``). Times, in
one run (best of ``--repeat``, 2 threads unless ``--threads``):

- the recording read (``slamq.load_scans``, cold);
- the six maps scored against their scans (:func:`slamq.verdict.scans.record_consistency`,
  the recording cached);
- the whole verdict without ground truth (``sequence_evidence`` + ``sequence_verdict``:
  agreement, defect detectors and scans) with the scans and without them (the records
  without ``scans``), and their difference.

Usage::

    PYTHONPATH=python python benches/bench_verdict_scans.py [--scans 2500] [--beams 360]
        [--repeat 3] [--threads 2]
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import tempfile
import time
from pathlib import Path


def best(f, repeat: int) -> tuple[float, object]:
    """The best wall time of ``repeat`` calls and the last result; the CPU seconds of that
    call are in ``best.cpu`` (on a loaded machine the CPU time is what transfers)."""
    times, out = [], None
    for _ in range(repeat):
        t, c = time.perf_counter(), time.process_time()
        out = f()
        times.append((time.perf_counter() - t, time.process_time() - c))
    wall, best.cpu = min(times)
    return wall, out


def main() -> None:
    import pandas as pd

    from slamq.api import evaluate
    from slamq.sources.maps import load_map
    from slamq.sources.scans import load_scans
    from slamq.synth import LaserSpec, degrade, simulate, world
    from slamq.synth.truth import visible_map
    from slamq.synth.worldgen import save_world
    from slamq.synth.writers import write_groundtruth
    from slamq.synth.writers.rawlog import write_rawlog
    from slamq.verdict import scans as vs
    from slamq.verdict.evidence import sequence_evidence
    from slamq.verdict.ranking import summarize
    from slamq.verdict.rule import sequence_verdict

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--scans", type=int, default=2500)
    ap.add_argument("--beams", type=int, default=360)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args()

    t = time.perf_counter()
    d = Path(tempfile.mkdtemp())
    w = world(args.seed, kind="office", size=(100.0, 50.0))
    laser = LaserSpec(beams=args.beams, fov=2 * math.pi * (args.beams - 1) / args.beams)
    seq = simulate(w, seed=args.seed, noise="low", laser=laser,
                   length=0.05 * args.scans + 5.0)
    rawlog = write_rawlog(seq, d / "drive.rawlog")
    gt = write_groundtruth(seq, d / "gt.tum")
    seen = visible_map(seq)
    maps = {"seen": seen, "specks1": degrade(seen, "specks", 0.001, seed=1),
            "specks2": degrade(seen, "specks", 0.002, seed=2),
            "drift": degrade(seen, "drift", 1.0, seed=3),
            "doubling": degrade(seen, "doubling", 0.3, seed=4),
            "kinks": degrade(seen, "kinks", 1.0, seed=5)}
    rows = []
    for name, m in maps.items():
        path = save_world(m, d / f"{name}.yaml")
        q = evaluate(str(path))
        rows.append({**{k: v for k, v in q.to_dict().items() if k != "curve"},
                     "map": str(path), "algorithm": name, "sequence": "s", "run": 1,
                     "scans": str(rawlog), "trajectory": str(gt)})
    ok = pd.DataFrame(rows)
    loaded = {r["map"]: load_map(r["map"]) for r in rows}
    cells = max(m.values.size for m in maps.values())
    print(f"# {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"{args.threads} threads; 6 maps of {cells / 1e6:.2f} Mcells, {len(seq)} scans x "
          f"{args.beams} beams (setup {time.perf_counter() - t:.0f} s)")

    def read() -> object:
        vs._CACHE.clear()
        return load_scans(rawlog)

    s, _ = best(read, args.repeat)
    print(f"recording read (cold):                 {s * 1e3:8.1f} ms wall, "
          f"{best.cpu * 1e3:8.1f} ms CPU")
    vs.recording(rawlog)

    def six() -> list:
        return [vs.record_consistency(r, loaded[r["map"]], threads=args.threads)
                for r in rows]

    s, out = best(six, args.repeat)
    print(f"6 maps against their scans:            {s * 1e3:8.1f} ms wall, "
          f"{best.cpu * 1e3:8.1f} ms CPU (violation shares "
          f"{', '.join(f'{c.violation_share:.3f}' for c in out)})")

    def verdict(frame: pd.DataFrame) -> dict:
        vs._CACHE.clear()
        ev = sequence_evidence(frame, "s", threads=args.threads, loaded=loaded)
        return sequence_verdict(summarize(frame), "s", ev)

    with_s, v = best(lambda: verdict(ok), args.repeat)
    with_cpu = best.cpu
    without_s, v0 = best(lambda: verdict(ok.drop(columns="scans")), args.repeat)
    without_cpu = best.cpu
    print(f"verdict without scans:                 {without_s * 1e3:8.1f} ms wall, "
          f"{without_cpu * 1e3:8.1f} ms CPU (best {v0['best']})")
    print(f"verdict with scans (recording read):   {with_s * 1e3:8.1f} ms wall, "
          f"{with_cpu * 1e3:8.1f} ms CPU (best {v['best']})")
    print(f"  the scans' share:                    {(with_s - without_s) * 1e3:8.1f} ms wall, "
          f"{(with_cpu - without_cpu) * 1e3:8.1f} ms CPU ({with_s / without_s:.2f}x wall)")


if __name__ == "__main__":
    main()
