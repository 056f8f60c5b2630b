"""Benchmark: slamq.evaluate vs slamq.reference (literal) vs a best-effort OpenCV pipeline.

Run ``python benches/bench.py`` (``--quick`` skips the two ~64-million-cell maps). Prints one
table per map and writes benches/RESULTS.md with the machine and the date. ``--dense`` runs
only the busy-map cases of issue 15 (1-Mcell crops of the densest parts of real maps, the
broken hector_odom map among them, and the graded maps), one thread, printed and not written
unless ``--out`` is given; ``--stages`` adds the Rust per-stage table of each crop
(``cargo run --release --example stages``). Every timing is
the minimum of several runs in this one process; ratios compare numbers from the same run.
The busy-map cases are timed without the memory sampler (their peak is not reported), warm
(as when evaluating maps one after another) and with a cold heap (``malloc_trim`` first).
The bench asserts that slamq's numbers equal the reference's on every map.

Columns
-------
ms/Mcell : milliseconds per million cells (full evaluation: all three metrics, the full
           256-value enclosed-area sweep)
x slamq  : how many times slower than slamq at the same thread count
peak MB  : peak resident memory above the baseline during the call (sampled every 1 ms)
"""

from __future__ import annotations

import argparse
import ctypes
import datetime as dt
import os
import platform
import sys
import threading
import time
from pathlib import Path
from typing import Callable

import cv2
import numpy as np

import slamq
from slamq.metrics import reference
from slamq.params import Params

HERE = Path(__file__).resolve().parent
SHARED = Path(os.environ.get("SLAMQ_SHARED_DATA", HERE.parent.parent / "shared" / "data"))


# ---------------------------------------------------------------------------------------------
# the best-effort OpenCV pipeline, as a careful user would write it


def otsu_table_numpy(hist_known: np.ndarray, n_unknown: int) -> np.ndarray:
    """Otsu threshold for every unknown value at once (vectorised between-class variance)."""
    h = np.tile(hist_known.astype(np.float64), (256, 1))
    h[np.arange(256), np.arange(256)] += n_unknown
    p = h / h.sum(axis=1, keepdims=True)
    i = np.arange(256, dtype=np.float64)
    q1 = np.cumsum(p, axis=1)
    m1 = np.cumsum(p * i, axis=1)
    mu = m1[:, -1:]
    with np.errstate(divide="ignore", invalid="ignore"):
        sigma = (mu * q1 - m1) ** 2 / (q1 * (1.0 - q1))
    eps = np.finfo(np.float32).eps
    sigma[(np.minimum(q1, 1 - q1) < eps) | ~np.isfinite(sigma)] = 0.0
    best = sigma.argmax(axis=1)
    best[sigma.max(axis=1) <= 0] = 0
    return best


def opencv_pipeline(m: slamq.OccupancyMap, p: Params) -> dict:
    v, unk = m.values, m.unknown
    known_vals = v[~unk]
    n = known_vals.size
    d = 255 - known_vals.astype(np.int64)
    occupied = int(np.count_nonzero(d * n > d.sum())) if n else 0
    # corners: float filters and cornerHarris
    s = np.where(unk, 0, v).astype(np.float32)
    g = cv2.GaussianBlur(s, (5, 5), 0, borderType=cv2.BORDER_REFLECT_101)
    lap = cv2.Laplacian(g, cv2.CV_32F, ksize=1, borderType=cv2.BORDER_REFLECT_101)
    mask = (lap > p.log_threshold * 255).astype(np.uint8)
    _, lab, stats, _ = cv2.connectedComponentsWithStats(mask, connectivity=8)
    keep = stats[:, cv2.CC_STAT_AREA] >= p.min_dot_area
    keep[0] = False
    mask = keep[lab].astype(np.float32)
    r = cv2.cornerHarris(mask, 2, 3, p.harris_k, borderType=cv2.BORDER_REFLECT_101)
    rmax = float(r.max())
    corners = 0
    if rmax > 0:
        cm = (r > p.harris_quality * rmax).astype(np.uint8)
        corners = cv2.connectedComponents(cm, connectivity=8)[0] - 1
    # enclosed areas: one labelling per distinct binarisation
    hist = np.bincount(known_vals, minlength=256)
    table = otsu_table_numpy(hist, int(unk.sum()))
    present = np.flatnonzero(hist)
    counts = {}
    curve = []
    for u in p.sweep_values:
        t = int(table[u])
        cut = int(present[present > t][0]) if (present > t).any() else 256
        key = (cut, bool(unk.any() and u > t))
        if key not in counts:
            free = np.where(unk, np.uint8(key[1]), (v >= cut).astype(np.uint8)).astype(np.uint8)
            k, _, st, _ = cv2.connectedComponentsWithStats(free, connectivity=8)
            x, y, w_, h_, area = (st[1:, i] for i in range(5))
            inner = (x > 0) & (y > 0) & (x + w_ < v.shape[1]) & (y + h_ < v.shape[0])
            counts[key] = int(np.count_nonzero(inner & (area >= p.min_area)))
        curve.append(counts[key])
    return {"occupied": occupied, "corners": corners, "enclosed": max(curve)}


# ---------------------------------------------------------------------------------------------
# maps


def tile(m: slamq.OccupancyMap, k: int) -> slamq.OccupancyMap:
    return slamq.OccupancyMap(np.tile(m.values, (k, k)), np.tile(m.unknown, (k, k)),
                              source=f"{m.source} tiled {k}x{k}")


def synthetic(size: int = 8192, seed: int = 1) -> slamq.OccupancyMap:
    """A building of rooms and corridors: walls 0, free 254, unknown 205 outside and in
    unexplored rooms, with sensor noise dots and a graded band (probability-style cells)."""
    rng = np.random.default_rng(seed)
    v = np.full((size, size), 205, np.uint8)
    unk = np.ones((size, size), bool)
    m = size // 16
    v[m:-m, m:-m] = 254
    unk[m:-m, m:-m] = False
    room = 96
    for r0 in range(m, size - m, room):
        v[r0:r0 + 3, m:-m] = 0
    for c0 in range(m, size - m, room):
        v[m:-m, c0:c0 + 3] = 0
    # doors
    doors = rng.integers(m, size - m, size=(4000, 2))
    for r, c in doors:
        v[r:r + 12, c:c + 12] = np.where(v[r:r + 12, c:c + 12] == 0, 254, v[r:r + 12, c:c + 12])
    # unexplored rooms
    for _ in range(600):
        r, c = rng.integers(m, size - m - room, size=2)
        unk[r:r + room // 2, c:c + room // 2] = True
        v[r:r + room // 2, c:c + room // 2] = 205
    noise = rng.random((size, size)) < 0.0005
    v[noise & ~unk] = 0
    return slamq.OccupancyMap(v, unk, source=f"synthetic {size}x{size}")


def bench_maps(quick: bool) -> list[slamq.OccupancyMap]:
    maps = []
    largest = SHARED / "maps" / "base_model_mu_building" / "mu_gm.yaml"
    graded = SHARED / "maps" / "utexas_gdc_large" / "3" / "3.yaml"
    if largest.exists():
        mu = slamq.load_map(largest)
        maps.append(mu)
        if graded.exists():
            maps.append(slamq.load_map(graded))
        if not quick:
            maps.append(tile(mu, 4))
    else:
        print(f"(corpus not found at {SHARED}: shared maps skipped)", file=sys.stderr)
    maps.append(synthetic(2048 if quick else 8192))
    return maps


# the busy maps of issue 15: 1-Mcell crops of the densest parts of real maps, and graded maps

DENSE_SOURCES = [
    # (path under maps/, label)
    ("base_model_mu_building/mu_gm.yaml", "mu_gm interior"),
    ("awabot_trajectoire4_4/trajectoire4_4_hector_odom.yaml", "awabot hector_odom (broken)"),
    ("utexas_gdc_large/3/3.yaml", "utexas 3 (graded)"),
    ("yogik10_slam_maps_eval/map_fastslam.pgm", "yogik10 fastslam"),
]
GRADED_SOURCES = [
    ("utexas_gdc_large/3/3.yaml", "utexas 3, whole map (graded)"),
    ("awabot_trajectoire4_4/trajectoire4_4_cartographer_1.yaml",
     "awabot cartographer, whole map (graded, unknown 128)"),
]


def densest_crop(m: slamq.OccupancyMap, side: int = 1000, stride: int = 20) -> slamq.OccupancyMap:
    """The side x side window (on a stride grid, first on ties) with the most known cells."""
    h, w = m.values.shape
    known = np.zeros((h + 1, w + 1), np.int64)
    known[1:, 1:] = (~m.unknown).cumsum(0).cumsum(1)
    rs = np.arange(0, max(1, h - side + 1), stride)
    cs = np.arange(0, max(1, w - side + 1), stride)
    r1 = np.minimum(rs + side, h)[:, None]
    c1 = np.minimum(cs + side, w)[None, :]
    n = known[r1, c1] - known[rs[:, None], c1] - known[r1, cs[None, :]] + known[rs[:, None], cs]
    i, j = np.unravel_index(int(np.argmax(n)), n.shape)
    r, c = int(rs[i]), int(cs[j])
    return slamq.OccupancyMap(np.ascontiguousarray(m.values[r:r + side, c:c + side]),
                              np.ascontiguousarray(m.unknown[r:r + side, c:c + side]),
                              source=f"{m.source} crop at ({r}, {c})")


def dense_maps() -> list[tuple[str, slamq.OccupancyMap]]:
    out = []
    for rel, label in DENSE_SOURCES:
        path = SHARED / "maps" / rel
        if not path.exists():
            print(f"(dense case {label} skipped: {path} not found)", file=sys.stderr)
            continue
        out.append((label, densest_crop(slamq.load_map(path))))
    for rel, label in GRADED_SOURCES:
        path = SHARED / "maps" / rel
        if not path.exists():
            print(f"(graded case {label} skipped: {path} not found)", file=sys.stderr)
            continue
        out.append((label, slamq.load_map(path)))
    return out


def stage_table(m: slamq.OccupancyMap, runs: int) -> list[str]:
    """The Rust per-stage timing of one map (rust/examples/stages.rs), or why not."""
    import subprocess
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        raw = Path(tmp) / "map.raw"
        raw.write_bytes(m.values.tobytes() + m.unknown.astype(np.uint8).tobytes())
        h, w = m.values.shape
        cmd = ["cargo", "run", "-q", "--release", "--example", "stages", "--",
               str(raw), str(h), str(w), str(runs)]
        try:
            res = subprocess.run(cmd, cwd=HERE.parent, capture_output=True, text=True,
                                 check=False)
        except FileNotFoundError:
            return ["(stage table skipped: cargo not found)"]
    if res.returncode != 0:
        return [f"(stage table failed: {res.stderr.strip()[-300:]})"]
    return res.stdout.strip().splitlines()


def run_dense(runs: int, reference_check: bool, stages: bool) -> list[str]:
    # the three metrics of the issue (and of the OpenCV pipeline): no canonical corners (the
    # default since 2026-11-27); slamq's time includes the wall angle, which evaluate always
    # computes (0.15-0.31x the three metrics; rust/examples/stages times both)
    p = Params(canonical_resolution=0)
    cases = dense_maps()
    if not cases:
        return [f"(busy-map cases skipped: corpus not found at {SHARED})"]
    cv2.setNumThreads(1)
    rows, lines = [], []
    for label, m in cases:
        mc = m.values.size / 1e6
        t_s, q = timed_plain(lambda m=m: slamq.evaluate(m, params=p, threads=1, curve=True),
                             runs)
        t_o, o = timed_plain(lambda m=m: opencv_pipeline(m, p), max(1, runs // 3))
        t_sc, _ = timed_plain(lambda m=m: slamq.evaluate(m, params=p, threads=1, curve=True),
                              runs, trim=True)
        t_oc, _ = timed_plain(lambda m=m: opencv_pipeline(m, p), max(1, runs // 3), trim=True)
        assert (q.occupied, q.corners, q.enclosed_areas) == (
            o["occupied"], o["corners"], o["enclosed"]), f"{label}: slamq != OpenCV"
        if reference_check:
            ref = reference.evaluate(m, curve=True, params=p)
            diffs = q.differences(ref)
            assert not diffs, f"{label}: slamq != reference: {diffs}"
        rows.append((label, m, t_s * 1e3 / mc, t_o * 1e3 / mc, q, t_sc * 1e3 / mc,
                     t_oc * 1e3 / mc))
        if stages:
            lines += [f"#### stages: {label} ({m.values.shape[0]} x {m.values.shape[1]})", ""]
            lines += stage_table(m, max(runs, 10)) + [""]
    check = "OpenCV pipeline and reference" if reference_check else "OpenCV pipeline"
    table = [
        "### busy maps (issue 15): one thread, all three metrics, full sweep "
        "(canonical corners off; slamq also computes the wall angle)",
        "",
        f"minimum of {runs} runs (OpenCV: {max(1, runs // 3)}); every result equal to the "
        f"{check}; cold heap: the same after `malloc_trim(0)` before each call (freed heap "
        "handed back to the OS, so that the call faults its working memory in anew)",
        "",
        "| map | shape | known | grey levels | slamq ms/Mcell | OpenCV ms/Mcell | x slamq | "
        "slamq cold heap | OpenCV cold heap | corners | enclosed |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for label, m, ms, mo, q, msc, moc in rows:
        levels = len(np.unique(m.values[~m.unknown]))
        table.append(
            f"| {label} | {m.values.shape[0]} x {m.values.shape[1]} | "
            f"{(~m.unknown).mean():.2f} | {levels} | {ms:.2f} | {mo:.1f} | {mo / ms:.1f} | "
            f"{msc:.2f} | {moc:.1f} | {q.corners} | {q.enclosed_areas} |")
    crops = [r for r in rows if "whole map" not in r[0]]
    if crops:
        ms = [r[2] for r in crops]
        ratio = [r[3] / r[2] for r in crops]
        cold = [r[5] for r in crops]
        ratio_cold = [r[6] / r[5] for r in crops]
        table += ["", f"crops: mean {np.mean(ms):.2f} ms/Mcell, worst {max(ms):.2f} ms/Mcell, "
                      f"lowest ratio to OpenCV {min(ratio):.1f}x; cold heap: mean "
                      f"{np.mean(cold):.2f}, worst {max(cold):.2f}, lowest ratio "
                      f"{min(ratio_cold):.1f}x", ""]
    return table + lines


# ---------------------------------------------------------------------------------------------
# timing


def _trim() -> None:
    """Give freed heap memory back to the OS (glibc), so that RSS growth during the next call
    measures that call's own allocations rather than reuse of memory kept from earlier ones."""
    try:
        ctypes.CDLL("libc.so.6").malloc_trim(0)
    except (OSError, AttributeError):
        pass


class PeakRSS:
    """Peak resident memory above the level at entry, sampled every millisecond."""

    def __init__(self) -> None:
        self.peak = 0
        self._stop = threading.Event()

    @staticmethod
    def rss() -> int:
        with open("/proc/self/statm") as fh:
            return int(fh.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")

    def __enter__(self) -> PeakRSS:
        _trim()
        self.base = self.rss()
        self._t = threading.Thread(target=self._run, daemon=True)
        self._t.start()
        return self

    def _run(self) -> None:
        while not self._stop.wait(0.001):
            self.peak = max(self.peak, self.rss() - self.base)

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._t.join()
        self.peak = max(self.peak, self.rss() - self.base)


def timed(fn: Callable[[], object], runs: int) -> tuple[float, int, object]:
    best, peak, out = float("inf"), 0, None
    for _ in range(runs):
        with PeakRSS() as mem:
            t0 = time.perf_counter()
            out = fn()
            best = min(best, time.perf_counter() - t0)
        peak = max(peak, mem.peak)
    return best, peak, out


def timed_plain(fn: Callable[[], object], runs: int, trim: bool = False
                ) -> tuple[float, object]:
    """The minimum time of ``runs`` calls, without the RSS sampler of :func:`timed` (a
    thread polling /proc every millisecond and ``malloc_trim`` before each call, which makes
    every call fault its working memory in anew: 0.4-0.9 ms/Mcell on the busy maps).
    ``trim``: still call ``malloc_trim(0)`` before each call (cold heap)."""
    best, out = float("inf"), None
    for _ in range(runs):
        if trim:
            _trim()
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="skip the ~64-Mcell maps")
    ap.add_argument("--runs", type=int, default=5, help="runs per slamq/OpenCV timing")
    ap.add_argument("--no-reference", action="store_true", help="skip the literal reference")
    ap.add_argument("--out", default=None,
                    help="where to write the results (default benches/RESULTS.md; with "
                         "--dense nothing is written unless given)")
    ap.add_argument("--dense", action="store_true",
                    help="only the busy-map cases (dense crops, broken map, graded maps)")
    ap.add_argument("--stages", action="store_true",
                    help="with the busy maps, the Rust per-stage table of each (needs cargo)")
    args = ap.parse_args()
    if args.dense:
        out = run_dense(args.runs, not args.no_reference, args.stages)
        print("\n".join(out))
        if args.out:
            Path(args.out).write_text("\n".join(out) + "\n")
        return 0
    args.out = args.out or str(HERE / "RESULTS.md")
    cores = os.cpu_count() or 1
    p = Params()
    lines = [
        "# slamq benchmark results",
        "",
        f"- date: {dt.datetime.now(dt.timezone.utc):%Y-%m-%d %H:%M UTC}",
        f"- machine: {platform.machine()}, {cores} cores, {platform.processor() or 'cpu ?'}, "
        f"Python {platform.python_version()}, OpenCV {cv2.__version__}, numpy {np.__version__}",
        f"- command: `python benches/bench.py{' --quick' if args.quick else ''}`; "
        f"minimum of {args.runs} runs (reference: 1 run)",
        "- full evaluation = all three metrics and the full 256-value enclosed-area sweep",
        "",
    ]
    for m in bench_maps(args.quick):
        cells = m.values.size
        mc = cells / 1e6
        rows = []
        results = {}
        for threads in (1, cores):
            cv2.setNumThreads(threads)
            t, mem, q = timed(lambda m=m, th=threads: slamq.evaluate(m, threads=th, curve=True),
                              args.runs)
            results[("slamq", threads)] = (t, mem, q)
            t, mem, o = timed(lambda m=m: opencv_pipeline(m, p), max(1, args.runs // 2))
            results[("opencv", threads)] = (t, mem, o)
        cv2.setNumThreads(-1)
        if not args.no_reference:
            cv2.setNumThreads(1)
            t, mem, ref = timed(lambda m=m: reference.evaluate(m, curve=True), 1)
            cv2.setNumThreads(-1)
            results[("reference", 1)] = (t, mem, ref)
            diffs = results[("slamq", 1)][2].differences(ref)
            assert not diffs, f"{m.source}: slamq != reference: {diffs}"
            for threads in (1, cores):
                assert results[("slamq", threads)][2] == results[("slamq", 1)][2]
        q = results[("slamq", 1)][2]
        o = results[("opencv", 1)][2]
        for (name, threads), (t, mem, _) in results.items():
            base = results[("slamq", threads)][0]
            rows.append((name, threads, t * 1e3, t * 1e3 / mc, t / base, mem / 1e6, mem / cells))
        title = (f"{m.source}: {m.values.shape[0]} x {m.values.shape[1]} = {mc:.1f} Mcells, "
                 f"{len(np.unique(m.values[~m.unknown]))} known grey levels")
        table = [
            f"### {title}",
            "",
            f"slamq: occupied {q.occupied}, corners {q.corners}, enclosed {q.enclosed_areas} "
            f"(u={q.enclosed_unknown_value}); OpenCV pipeline: occupied {o['occupied']}, "
            f"corners {o['corners']}, enclosed {o['enclosed']}"
            + ("" if args.no_reference else "; reference: identical to slamq"),
            "",
            "| implementation | threads | ms | ms/Mcell | x slamq | peak MB | bytes/cell |",
            "|---|---:|---:|---:|---:|---:|---:|",
        ]
        table += [
            f"| {n} | {th} | {ms:.1f} | {mpm:.2f} | {ratio:.1f} | {mb:.0f} | {bpc:.2f} |"
            for n, th, ms, mpm, ratio, mb, bpc in rows
        ]
        s1, sn = results[("slamq", 1)][0], results[("slamq", cores)][0]
        table += ["", f"slamq {cores} threads vs 1: {s1 / sn:.2f}x throughput", ""]
        print("\n".join(table), flush=True)
        lines += table
    dense = run_dense(args.runs, not args.no_reference, args.stages)
    print("\n".join(dense), flush=True)
    lines += dense
    Path(args.out).write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
