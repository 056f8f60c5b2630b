"""Benchmark: the verdict of 6 maps of about 2 Mcells with their scans (issue 41: "<= 3 s on
2 cores"; docs/spec.md section 9, "Against its own scans").

A generated office world of about 2 Mcells (100 x 50 m at 0.05 m), a drive of ``--scans``
scans of ``--beams`` beams written as an MRPT rawlog with its exact path; six maps of the
world (the walls the laser saw, and five damaged copies: specks twice, drift, doubling,
kinks), each record naming the rawlog (``scans``) and the path (``trajectory``). Times, in
one run (best of ``--repeat``, 2 threads unless ``--threads``):

- the recording read (``slamq.load_scans``, cold);
- the six maps scored against their scans (:func:`slamq.verdict.scans.record_consistency`,
  the recording cached), and their paths split in time (:func:`slamq.scan_split` at its
  defaults, and as the verdict computes it, :func:`slamq.verdict.scans.record_split`: 300
  scans drawn and tested a half);
- the six paths' local shares (:func:`slamq.verdict.scans.record_local`, docs/spec.md 7f);
- the whole verdict without ground truth (``sequence_evidence`` + ``sequence_verdict``:
  agreement, defect detectors and scans) with the scans and without them (the records
  without ``scans``), and their difference; and with the scans when every record's path
  is the drive's odometry (its split share above 2%), with the local floor off (the
  default) and on (``slamq.verdict.rule.LOCAL_RATIO`` set: the evidence computes the six
  local shares too, the verdict's worst case).

Then the stages of the verdict, each on its own with 1 thread (CPU seconds: what they cost,
whatever else runs on the machine), and the whole verdict with ``--threads``, in a fresh
process per round; with ``--base DIR`` (the ``python/`` folder of another checkout, its
extension built in it) the same child runs that build too, alternating with this one, and
each figure is printed with the ratio base / this measured in the same run, and whether
both builds gave the same verdict and evidence:

- scans: the six maps against their scans (``record_consistency``, the recording cached);
- split: the six records' paths against their scans split in time as the verdict scores
  them (:func:`slamq.verdict.scans.record_split`, docs/spec.md 7e with 300 scans a half;
  a base without it: :func:`slamq.scan_split` with the same arguments);
- defects: ``detect_defects`` of the six maps;
- registration: ``register_many`` of the six maps;
- pairs: ``agreement`` (``align="auto"``) minus that registration (the 30 ordered pairs);
- missing walls: ``missing_walls`` of that agreement;
- verdict: ``sequence_evidence`` + ``sequence_verdict`` with the scans, 1 thread and
  ``--threads`` threads (wall and CPU seconds).

Usage::

    PYTHONPATH=python python benches/bench_verdict_scans.py [--scans 2500] [--beams 360]
        [--repeat 3] [--threads 2] [--rounds 2] [--base ../base/python]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

#: One round of the stages in a fresh process: argv = rows.pkl, threads, repeat.
STAGES_CHILD = r"""
import hashlib, json, os, sys, time
import pandas as pd
import slamq
from slamq.metrics.agreement import agreement, missing_walls
from slamq.metrics.defects import detect_defects
from slamq.metrics.register import register_many
from slamq.sources.maps import load_map
from slamq.verdict import scans as vs
from slamq.verdict.evidence import sequence_evidence
from slamq.verdict.ranking import summarize
from slamq.verdict.rule import sequence_verdict

ok = pd.read_pickle(sys.argv[1])
threads, repeat = int(sys.argv[2]), int(sys.argv[3])
loaded = {r: load_map(r) for r in ok["map"]}
maps = {r["algorithm"]: loaded[r["map"]] for r in ok.to_dict("records")}
vs.recording(ok["scans"].iloc[0])
out = {"slamq": os.path.dirname(slamq.__file__)}

def split(r, th):
    if hasattr(vs, "record_split"):
        return vs.record_split(r, threads=th)
    from slamq import load_trajectory, scan_split
    return scan_split(vs.recording(r["scans"]), load_trajectory(r["trajectory"]),
                      max_draw=300, max_test=300, threads=th)

def best(name, f):
    w, c, r = [], [], None
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        r = f()
        w.append(time.perf_counter() - t0)
        c.append(time.process_time() - c0)
    out[name] = [min(w), min(c)]
    return r

best("scans", lambda: [vs.record_consistency(r, loaded[r["map"]], threads=1)
                       for r in ok.to_dict("records")])
best("split", lambda: [split(r, 1) for r in ok.to_dict("records")])
best("defects", lambda: [detect_defects(m) for m in maps.values()])
best("registration", lambda: register_many(maps, threads=1))
a = best("agreement", lambda: agreement(maps, align="auto", threads=1))
out["pairs"] = [out["agreement"][0] - out["registration"][0],
                out["agreement"][1] - out["registration"][1]]
best("missing walls", lambda: missing_walls(a, maps))

def verdict(th, frame):
    vs._CACHE.clear()
    ev = sequence_evidence(frame, "s", threads=th, loaded=loaded)
    return ev, sequence_verdict(summarize(frame), "s", ev)

best("verdict, 1 thread", lambda: verdict(1, ok))
best(f"verdict, {threads} threads, no scans", lambda: verdict(threads, ok.drop(columns="scans")))
ev, v = best(f"verdict, {threads} threads", lambda: verdict(threads, ok))
out["best"] = v["best"]
out["same"] = hashlib.sha1(json.dumps([ev, v], sort_keys=True, default=repr)
                           .encode()).hexdigest()[:12]
print(json.dumps(out))
"""


def stages(python_dir: str | None, rows: Path, threads: int, repeat: int) -> dict:
    """One round of :data:`STAGES_CHILD` in a fresh process, importing slamq from
    ``python_dir`` (None: as this process does)."""
    env = dict(os.environ)
    if python_dir:
        env["PYTHONPATH"] = str(Path(python_dir).resolve())
    p = subprocess.run([sys.executable, "-c", STAGES_CHILD, str(rows), str(threads),
                        str(repeat)], capture_output=True, text=True, env=env, check=False)
    if p.returncode != 0:
        raise SystemExit(f"stages child failed ({python_dir or 'this build'}):\n{p.stderr}")
    return json.loads(p.stdout.strip().splitlines()[-1])


def load_average() -> str:
    try:
        return ", ".join(f"{v:.1f}" for v in os.getloadavg())
    except OSError:
        return "?"


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

    from slamq import Trajectory
    from slamq.api import evaluate
    from slamq.sources.maps import load_map
    from slamq.sources.scans import load_scans
    from slamq.synth import LaserSpec, degrade, simulate, world
    from slamq.synth.truth import visible_map
    from slamq.synth.worldgen import save_world
    from slamq.synth.writers import EPOCH, write_groundtruth
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
    ap.add_argument("--rounds", type=int, default=2,
                    help="fresh processes per build for the stages table")
    ap.add_argument("--base", default=None,
                    help="the python/ folder of another checkout to measure against")
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
          f"{best.cpu * 1e3:8.1f} ms CPU (violation / crossing shares "
          f"{', '.join(f'{c.violation_share:.3f}/{c.crossing_share:.3f}' for c in out)})")

    def split(**most: int) -> list:
        from slamq import load_trajectory, scan_split

        return [scan_split(vs.recording(r["scans"]), load_trajectory(r["trajectory"]),
                           threads=args.threads, **most) for r in rows]

    for label, most in (("defaults:", {}),
                        ("300 a half:", {"max_draw": 300, "max_test": 300})):
        s, out = best(lambda most=most: split(**most), args.repeat)
        print(f"6 paths, {label:11s}                {s * 1e3:8.1f} ms wall, "
              f"{best.cpu * 1e3:8.1f} ms CPU (split crossing shares "
              f"{', '.join(f'{c.crossing_share:.4f}' for c in out)})")

    s, out = best(lambda: [vs.record_local(r, threads=args.threads) for r in rows],
                  args.repeat)
    print(f"6 paths, local shares (7f):            {s * 1e3:8.1f} ms wall, "
          f"{best.cpu * 1e3:8.1f} ms CPU (local shares "
          f"{', '.join(format(c['local_crossing'], '.4f') for c in out)})")

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
    odom = d / "odom.tum"
    Trajectory.from_xy_yaw(EPOCH + seq.stamps, *seq.odom.T).write_tum(odom)
    drifting = ok.assign(trajectory=str(odom))
    odom_s, vo = best(lambda: verdict(drifting), args.repeat)
    ev = sequence_evidence(drifting, "s", threads=args.threads, loaded=loaded)
    splits = [f"{e['split_crossing']:.3f}" for e in ev["splits"].values()]
    print(f"verdict with scans, odometry paths:    {odom_s * 1e3:8.1f} ms wall, "
          f"{best.cpu * 1e3:8.1f} ms CPU (best {vo['best']}; split shares "
          f"{', '.join(splits)}; local shares computed: "
          f"{sum('local_crossing' in e for e in ev['splits'].values())})")
    from slamq.verdict import rule

    rule.LOCAL_RATIO = rule.SCAN_SHARE  # the local floor on (off by default)
    try:
        local_s, vl = best(lambda: verdict(drifting), args.repeat)
    finally:
        rule.LOCAL_RATIO = None
    print(f"  the same, local floor on:            {local_s * 1e3:8.1f} ms wall, "
          f"{best.cpu * 1e3:8.1f} ms CPU (best {vl['best']}; "
          f"{local_s / odom_s:.2f}x the floor off)")

    ok.to_pickle(d / "rows.pkl")
    builds = {"this": None} if args.base is None else {"base": args.base, "this": None}
    runs: dict[str, list[dict]] = {k: [] for k in builds}
    loads = [load_average()]
    for _ in range(args.rounds):
        for name, where in builds.items():
            runs[name].append(stages(where, d / "rows.pkl", args.threads, args.repeat))
            loads.append(load_average())
    keys = [k for k in runs["this"][0] if isinstance(runs["this"][0][k], list)]
    low = {b: {k: [min(r[k][i] for r in rs) for i in (0, 1)] for k in keys}
           for b, rs in runs.items()}
    print(f"\n# stages, best of {args.rounds} processes x {args.repeat} calls; load "
          f"(1, 5, 15 min) {loads[0]} before, {loads[-1]} after")
    head = f"{'stage':36s} {'this CPU s':>10s} {'wall s':>8s}"
    if "base" in low:
        head += f" {'base CPU s':>10s} {'wall s':>8s} {'CPU ratio':>9s} {'wall ratio':>10s}"
    print(head)
    for k in keys:
        (tw, tc), line = low["this"][k], ""
        if "base" in low:
            bw, bc = low["base"][k]
            line = f" {bc:10.3f} {bw:8.3f} {bc / tc:8.2f}x {bw / tw:9.2f}x"
        print(f"{k:36s} {tc:10.3f} {tw:8.3f}{line}")
    same = {r["same"] for rs in runs.values() for r in rs}
    print(f"verdict: best {runs['this'][0]['best']}; the same verdict and evidence in every "
          f"process{' of both builds' if 'base' in low else ''}: {len(same) == 1}")


if __name__ == "__main__":
    main()
