"""Batch throughput: 2,000 maps of 1 million cells, 1 vs 2 threads, maps/s, peak RSS.

Targets (issue 4): 2 threads >= 1.7x the 1-thread throughput; >= 100 maps/s end to end
(read, evaluate, write); peak RSS independent of the number of maps.

The maps are crops and copies of the real maps in ../shared/data, placed on 1000 x 1000
canvases (a larger map is cropped at a random window, a smaller one is pasted at a random
offset on an unknown canvas) and written as PGM to a temporary folder (about 1 MB each;
they stay in the page cache, so "read" means decoding, not disk I/O). Every measurement
runs ``slamq batch`` in a fresh subprocess that reports its own peak RSS, so the runs do
not share caches or memory; the subprocess imports the modules the batch uses before its
clock starts (import time is paid once per process, not per map).

``--dense`` (issue 15): 1-Mcell dense crops of real maps as PGM + YAML, 1 vs 2 threads,
with default parameters (canonical corners off) and with canonical corners on
(``canonical_resolution=0.07``), and each map's time by step. With the defaults it also
runs two 1-thread processes at once on half the maps each: what 2 cores give without any
sharing between threads, so "2 threads / two processes" is the part of the scaling the
threads lose (GIL, allocator, pool), apart from what the machine loses. Each row also
gives the seconds of the two steps that run on one thread whatever the thread count: the
walk that finds the runs, and the results file's closing step (from the last record to the
end: the Parquet file compacted); "the maps alone" is the 2 / 1-thread ratio without them.

    PYTHONPATH=python python benches/bench_batch.py            # 2,000 maps
    PYTHONPATH=python python benches/bench_batch.py --maps 400 # quicker

Prints a table; each ratio is computed from numbers measured in the same run.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

REPO = Path(__file__).resolve().parent.parent
CORPUS = Path(os.environ.get("SLAMQ_SHARED_DATA", REPO.parent / "shared" / "data")) / "maps"
SIDE = 1000

CHILD = r"""
import json, resource, sys, time
from slamq.batch import evaluate_many
from slamq.batch.runs import Discovery
# the modules a batch imports on first use, imported before the clock starts: library import
# time (pyarrow alone is ~0.3 s) is paid once per process, not per map
import cv2, pyarrow, pyarrow.parquet, yaml  # noqa: E401,F401
# pyarrow imports pandas the first time it builds an array (here: when the Parquet file is
# compacted at the end), ~0.4-0.6 s once per process
import pandas  # noqa: F401
import slamq.batch.records, slamq.metrics.evaluate  # noqa: E401,F401
import slamq.results.formats, slamq.results.store  # noqa: E401,F401
import slamq.sources.formats.map_server  # noqa: F401
src, out, threads, chunk = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
params = json.loads(sys.argv[5]) if len(sys.argv) > 5 else {}
t0 = time.perf_counter()
main0 = time.thread_time()
# the walk that finds the runs (what evaluate_many does first when given a folder), timed
# apart: it and the results file's closing step run on one thread, before and after the maps
runs = Discovery(src)
walk = time.perf_counter() - t0
n = failed = 0
last = t0
for rec in evaluate_many(runs, threads=threads, chunk_size=chunk, out=out, **params):
    n += 1
    failed += rec["error"] is not None
    last = time.perf_counter()
end = time.perf_counter()
dt = end - t0
ru = resource.getrusage(resource.RUSAGE_SELF)
print(json.dumps({"n": n, "failed": failed, "seconds": dt, "rss_mb": ru.ru_maxrss / 1024.0,
                  "cpu": ru.ru_utime + ru.ru_stime, "main_cpu": time.thread_time() - main0,
                  "walk": walk, "closing": end - last}))
"""


def corpus_images() -> list[np.ndarray]:
    """Grey images of the corpus maps (PGM/PNG), as uint8 arrays."""
    images = []
    for p in sorted(CORPUS.rglob("*")):
        if p.suffix.lower() not in (".pgm", ".png"):
            continue
        img = cv2.imread(str(p), cv2.IMREAD_GRAYSCALE)
        if img is not None and min(img.shape) >= 64:
            images.append(img)
    if not images:
        sys.exit(f"no corpus maps under {CORPUS} (set SLAMQ_SHARED_DATA)")
    return images


def make_map(src: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A SIDE x SIDE map: a random crop of ``src``, or ``src`` pasted on an unknown canvas."""
    canvas = np.full((SIDE, SIDE), 205, np.uint8)
    h, w = src.shape
    r0 = int(rng.integers(0, h - SIDE + 1)) if h > SIDE else 0
    c0 = int(rng.integers(0, w - SIDE + 1)) if w > SIDE else 0
    part = src[r0 : r0 + SIDE, c0 : c0 + SIDE]
    ph, pw = part.shape
    dr = int(rng.integers(0, SIDE - ph + 1))
    dc = int(rng.integers(0, SIDE - pw + 1))
    canvas[dr : dr + ph, dc : dc + pw] = part
    if rng.random() < 0.5:
        canvas = np.ascontiguousarray(canvas[:, ::-1])
    return canvas


def write_maps(folder: Path, n: int, seed: int = 0) -> None:
    """``n`` maps as ``<algorithm>/<sequence>/<run>/map.pgm`` (8 algorithms, 5 sequences)."""
    rng = np.random.default_rng(seed)
    images = corpus_images()
    for i in range(n):
        img = make_map(images[i % len(images)], rng)
        run = folder / f"alg{i % 8}" / f"seq{(i // 8) % 5}" / f"run{i:05d}"
        run.mkdir(parents=True, exist_ok=True)
        cv2.imwrite(str(run / "map.pgm"), img)


def write_dense_maps(folder: Path, n: int) -> int:
    """``n`` maps as ``<algorithm>/<sequence>/<run>/map.yaml`` + ``map.pgm``: the dense
    1-Mcell crops of ``bench.py --dense`` (the busiest 1000 x 1000 windows of four real
    maps), each in one of its 8 flips and turns by 90 degrees and with one cell changed, so
    that every file differs. Returns how many crops there were (0: no corpus)."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from bench import dense_maps

    crops = [m for name, m in dense_maps() if m.shape == (SIDE, SIDE)]
    for i in range(n if crops else 0):
        m = crops[i % len(crops)]
        img = np.where(m.unknown, 205, m.values).astype(np.uint8)
        k = (i // len(crops)) % 8
        img = np.rot90(img, k % 4)
        img = np.ascontiguousarray(img[:, ::-1] if k >= 4 else img)
        img[i % SIDE, (7 * i) % SIDE] = 254 if img[i % SIDE, (7 * i) % SIDE] != 254 else 0
        run = folder / f"alg{i % 8}" / f"seq{(i // 8) % 5}" / f"run{i:05d}"
        run.mkdir(parents=True, exist_ok=True)
        cv2.imwrite(str(run / "map.pgm"), img)
        (run / "map.yaml").write_text(
            "image: map.pgm\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\nnegate: 0\n"
            "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    return len(crops)


def per_map_costs(folder: Path) -> list[tuple[str, float]]:
    """One thread, in this process, median ms per map over every map: each step the batch
    takes for a map, timed alone."""
    import statistics

    import slamq
    from slamq.batch.records import content_hash

    maps = sorted(folder.rglob("map.yaml"))
    steps: dict[str, list[float]] = {}

    def t(name: str, fn):
        t0 = time.perf_counter()
        out = fn()
        steps.setdefault(name, []).append(1000 * (time.perf_counter() - t0))
        return out

    from slamq import native
    from slamq.models.quality import shade_source

    defaults = slamq.Params()
    for p in maps:
        t("hash (SHA-1 of YAML + PGM)", lambda p=p: content_hash(p))
        m = t("decode (load_map: read, parse YAML, PGM, thresholds)",
              lambda p=p: slamq.load_map(p))
        t("metrics, default (canonical corners off)", lambda m=m: slamq.evaluate(m, threads=1))
        t("metrics, canonical corners on (0.07 m)",
          lambda m=m: slamq.evaluate(m, threads=1, canonical_resolution=0.07))
    # Python's share of the metrics is a small difference of two large times: the minimum
    # of 7 runs of each on 48 maps, so that noise does not swamp it
    python = []
    for p in maps[:48]:
        m = slamq.load_map(p)
        full, core = [], []
        for _ in range(7):
            t0 = time.perf_counter()
            slamq.evaluate(m, threads=1)
            t1 = time.perf_counter()
            native.evaluate(m.values, m.unknown, defaults, 1, m.resolution, shade_source(m))
            t2 = time.perf_counter()
            full.append(t1 - t0)
            core.append(t2 - t1)
        python.append(1000 * (min(full) - min(core)))
    out = [(k, statistics.median(v)) for k, v in steps.items()]
    return out + [("  of which Python (slamq.evaluate - _core.evaluate: checks, MapQuality, "
                   "facts)", statistics.median(python))]


def start_batch(src: Path, out: Path, threads: int, chunk: int,
                params: dict | None = None) -> subprocess.Popen:
    """``slamq batch`` of ``src`` in a fresh subprocess (see :func:`run_batch`)."""
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(
        [str(REPO / "python")] + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else [])
    )
    if out.exists():
        out.unlink()
    return subprocess.Popen(
        [sys.executable, "-c", CHILD, str(src), str(out), str(threads), str(chunk),
         json.dumps(params or {})],
        env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )


def finish_batch(proc: subprocess.Popen, t0: float) -> dict:
    """What a batch started at ``t0`` reports: maps, failures, seconds in batch, CPU."""
    stdout, stderr = proc.communicate()
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        sys.exit(f"batch failed:\n{stderr}")
    res = json.loads(stdout.strip().splitlines()[-1])
    res["wall"] = wall
    return res


def run_batch(src: Path, out: Path, threads: int, chunk: int,
              params: dict | None = None) -> dict:
    t0 = time.perf_counter()
    return finish_batch(start_batch(src, out, threads, chunk, params), t0)


def run_two_processes(halves: tuple[Path, Path], tmp: Path, chunk: int,
                      params: dict | None = None) -> dict:
    """Two 1-thread batches at once, one per half of the maps: what 2 cores give with no
    thread of one process waiting for another (no shared GIL, allocator or pool). The
    result covers both halves: maps, and seconds until the later one finished its batch."""
    t0 = time.perf_counter()
    procs = [start_batch(h, tmp / f"half{i}.parquet", 1, chunk, params)
             for i, h in enumerate(halves)]
    res = [finish_batch(p, t0) for p in procs]
    return {"n": sum(r["n"] for r in res), "failed": sum(r["failed"] for r in res),
            "seconds": max(r["seconds"] for r in res), "wall": max(r["wall"] for r in res),
            "cpu": sum(r["cpu"] for r in res), "main_cpu": sum(r["main_cpu"] for r in res),
            "walk": max(r["walk"] for r in res), "closing": max(r["closing"] for r in res)}


def halves(folder: Path, dest: Path) -> tuple[Path, Path]:
    """Two folders of symlinks to every other run of ``folder`` (same files, no copies)."""
    return (subset(folder, None, dest / "a", start=0, step=2),
            subset(folder, None, dest / "b", start=1, step=2))


def subset(folder: Path, n: int | None, dest: Path, start: int = 0, step: int = 1) -> Path:
    """A folder of symlinks to the first ``n`` (None: all) of every ``step``-th run from
    ``start`` (same files, no copies)."""
    runs = sorted(folder.glob("*/*/*"), key=lambda p: p.name)[start::step][:n]
    for r in runs:
        link = dest / r.relative_to(folder)
        link.parent.mkdir(parents=True, exist_ok=True)
        link.symlink_to(r, target_is_directory=True)
    return dest


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--maps", type=int, default=2000, help="maps in the big run (default 2000)")
    ap.add_argument("--scaling-maps", type=int, default=1000,
                    help="maps for the 1- vs 2-thread comparison (default 1000)")
    ap.add_argument("--chunk-size", type=int, default=32)
    ap.add_argument("--repeat", type=int, default=3,
                    help="--dense: runs of each configuration, 1 and 2 threads alternating; "
                         "the table gives their medians (default 3)")
    ap.add_argument("--keep", action="store_true", help="keep the temporary folder")
    ap.add_argument("--dense", action="store_true",
                    help="issue 15: 1-Mcell dense crops of real maps as PGM + YAML (not "
                         "mostly-unknown canvases), 1 vs 2 threads, and each map's time by step")
    args = ap.parse_args()
    if args.dense:
        dense(args)
        return

    load0 = os.getloadavg()[0]
    tmp = Path(tempfile.mkdtemp(prefix="slamq-bench-batch-"))
    try:
        t0 = time.perf_counter()
        maps = tmp / "maps"
        write_maps(maps, args.maps)
        gen = time.perf_counter() - t0
        size = sum(p.stat().st_size for p in maps.rglob("*.pgm")) / 1e6
        print(f"wrote {args.maps} maps of {SIDE}x{SIDE} cells ({size:.0f} MB) in {gen:.1f} s "
              f"to {maps}; CPUs available: {len(os.sched_getaffinity(0))}")

        small = subset(maps, min(args.scaling_maps, args.maps), tmp / "small")
        quarter = subset(maps, max(1, args.maps // 4), tmp / "quarter")
        rows = []
        t1 = run_batch(small, tmp / "t1.parquet", 1, args.chunk_size)
        t2 = run_batch(small, tmp / "t2.parquet", 2, args.chunk_size)
        rows.append((f"{t1['n']} maps, 1 thread", t1))
        rows.append((f"{t2['n']} maps, 2 threads", t2))
        q = run_batch(quarter, tmp / "q.parquet", 2, args.chunk_size)
        rows.append((f"{q['n']} maps, 2 threads", q))
        full = run_batch(maps, tmp / "full.parquet", 2, args.chunk_size)
        rows.append((f"{full['n']} maps, 2 threads", full))

        print()
        print("| run | maps/s (in batch) | maps/s (process wall) | CPU s / wall s | "
              "peak RSS MB | failed |")
        print("|---|---|---|---|---|---|")
        for name, r in rows:
            print(f"| {name} | {r['n'] / r['seconds']:.1f} | {r['n'] / r['wall']:.1f} | "
                  f"{r['cpu'] / r['wall']:.2f} | {r['rss_mb']:.0f} | {r['failed']} |")
        ratio = (t2["n"] / t2["seconds"]) / (t1["n"] / t1["seconds"])
        print()
        print(f"2-thread / 1-thread throughput: {ratio:.2f}x (target >= 1.7x)")
        eff = (t2["n"] / t2["cpu"]) / (t1["n"] / t1["cpu"])
        print(f"maps per CPU-second, 2 threads / 1 thread: {eff:.2f} (>= 1.0: no parallel "
              f"overhead, so a ratio below 1.7x means the batch did not get 2 free cores)")
        print(f"end to end, {full['n']} maps: {full['n'] / full['seconds']:.1f} maps/s "
              f"(target >= 100)")
        print(f"peak RSS {q['n']} vs {full['n']} maps: {q['rss_mb']:.0f} vs "
              f"{full['rss_mb']:.0f} MB ({full['rss_mb'] / q['rss_mb']:.2f}x; "
              f"independent of the map count means ~1.0x)")
        per_map_ms = 1000.0 * t1["seconds"] / t1["n"]
        print(f"load average (1 min) before / after: {load0:.1f} / {os.getloadavg()[0]:.1f} "
              f"on {len(os.sched_getaffinity(0))} CPUs (other work competes for the CPUs; "
              f"'CPU s / wall s' is how many cores the batch actually got)")
        print(f"one thread spends {per_map_ms:.1f} ms per map (hash + decode + metrics + "
              f"write); 100 maps/s on 2 threads needs <= 20 ms")
    finally:
        if args.keep:
            print(f"kept {tmp}")
        else:
            shutil.rmtree(tmp, ignore_errors=True)


def dense(args: argparse.Namespace) -> None:
    load0 = os.getloadavg()[0]
    tmp = Path(tempfile.mkdtemp(prefix="slamq-bench-dense-"))
    try:
        maps = tmp / "maps"
        if not write_dense_maps(maps, args.scaling_maps):
            print(f"skipped: no corpus under {CORPUS}")
            return
        print(f"{args.scaling_maps} dense 1-Mcell crops (PGM + YAML) in {maps}; CPUs "
              f"available: {len(os.sched_getaffinity(0))}")
        print(f"\nEach row: the median of {args.repeat} runs, 1- and 2-thread runs "
              "alternating (so that a slow spell of the machine hits both); the ratio is that "
              "of the medians, the range that of the runs paired in order.\n")
        print("| run | maps/s (in batch), median | range | ms per map | CPU s / wall s | "
              "main thread CPU ms per map | walk + closing, s | failed |")
        print("|---|---:|---:|---:|---:|---:|---:|---:|")
        split = halves(maps, tmp / "halves")
        for label, params in (("default", {}),
                              ("canonical_resolution=0.07", {"canonical_resolution": 0.07})):
            ones, twos, procs = [], [], []
            for _ in range(args.repeat):
                ones.append(run_batch(maps, tmp / "t1.parquet", 1, args.chunk_size, params))
                twos.append(run_batch(maps, tmp / "t2.parquet", 2, args.chunk_size, params))
                if label == "default":
                    procs.append(run_two_processes(split, tmp, args.chunk_size, params))
            rows = []
            for name, runs in ((f"{label}, 1 thread", ones), (f"{label}, 2 threads", twos),
                               (f"{label}, two 1-thread processes, half the maps each",
                                procs)):
                if not runs:
                    continue
                rates = sorted(r["n"] / r["seconds"] for r in runs)
                r = sorted(runs, key=lambda r: r["n"] / r["seconds"])[len(runs) // 2]
                rows.append(r)
                print(f"| {name} | {rates[len(rates) // 2]:.1f} | {rates[0]:.0f}-{rates[-1]:.0f} | "
                      f"{1000 * r['seconds'] / r['n']:.2f} | {r['cpu'] / r['wall']:.2f} | "
                      f"{1000 * r['main_cpu'] / r['n']:.3f} | "
                      f"{r['walk']:.2f} + {r['closing']:.2f} | "
                      f"{sum(x['failed'] for x in runs)} |")
            t1, t2 = rows[:2]
            ratio = (t2["n"] / t2["seconds"]) / (t1["n"] / t1["seconds"])
            pairs = sorted((b["n"] / b["seconds"]) / (a["n"] / a["seconds"])
                           for a, b in zip(ones, twos))
            print(f"| {label}: 2 threads / 1 thread | {ratio:.2f}x (target >= 1.8x) | "
                  f"{pairs[0]:.2f}-{pairs[-1]:.2f}x | | | | | |")
            # the walk and the closing step run on one thread whatever the thread count
            apart = sorted((a["seconds"] - a["walk"] - a["closing"])
                           / (b["seconds"] - b["walk"] - b["closing"])
                           for a, b in zip(ones, twos))
            print(f"| {label}: 2 threads / 1 thread, the maps alone (batch s - walk - "
                  f"closing) | {apart[len(apart) // 2]:.2f}x | {apart[0]:.2f}-{apart[-1]:.2f}x "
                  "| | | | | |")
            if procs:
                tp = rows[2]
                ceiling = (tp["n"] / tp["seconds"]) / (t1["n"] / t1["seconds"])
                pairs = sorted((b["n"] / b["seconds"]) / (a["n"] / a["seconds"])
                               for a, b in zip(procs, twos))
                print(f"| {label}: two processes / 1 thread (what 2 cores allow) | "
                      f"{ceiling:.2f}x | | | | | | |")
                print(f"| {label}: 2 threads / two processes | "
                      f"{ratio / ceiling:.2f}x | {pairs[0]:.2f}-{pairs[-1]:.2f}x | | | | | |")
            if label == "default":
                first = t1
        costs = per_map_costs(maps)
        per_map = 1000 * first["seconds"] / first["n"]
        print("\none map, one thread, median ms (each step timed alone, in one process):\n")
        print("| step | ms | share of the default 1-thread batch's ms per map |\n"
              "|---|---:|---:|")
        for name, ms in costs:
            print(f"| {name} | {ms:.2f} | {100 * ms / per_map:.0f}% |")
        rest = per_map - costs[0][1] - costs[1][1] - costs[2][1]
        print(f"| the rest: discovery, records, Parquet, the thread pool (batch ms - hash - "
              f"decode - default metrics) | {rest:.2f} | {100 * rest / per_map:.0f}% |")
        print(f"\nload average before / after: {load0:.1f} / {os.getloadavg()[0]:.1f}")
    finally:
        if args.keep:
            print(f"kept {tmp}")
        else:
            shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
