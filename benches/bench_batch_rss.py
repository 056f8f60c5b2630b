"""Peak RSS of ``slamq batch`` against the number of maps (issue 11, item 10): flat?

Writes N tiny maps (20 x 20 PGM; flat layout ``seq<k>/<algorithm>_map_<run>.pgm``, 500 per
sequence folder, or ``--layout runs``: a folder per map) for each N, runs the real CLI
``slamq batch DIR --out results.<fmt>`` in a fresh subprocess per measurement, and reads
the child's peak RSS from ``os.wait4``.
Each size is run twice: a fresh batch, then a resume (every map already in the file).

    PYTHONPATH=python python benches/bench_batch_rss.py                  # 2,000 and 8,000
    PYTHONPATH=python python benches/bench_batch_rss.py --maps 2000 20000

Prints one line per run and the slope (KB per map) between the smallest and largest N.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

PER_FOLDER = 500
ALGOS = ("gmapping", "hector", "karto", "cartographer", "toolbox")


def make_maps(root: Path, n: int, layout: str = "flat") -> None:
    """``n`` 20 x 20 maps: a 10 x 10 obstacle in free space, its position varying.

    ``layout``: "flat" (``seq<k>/<algorithm>_map_<run>.pgm``, 500 per folder) or "runs"
    (``<algorithm>/seq<k>/<run>/map.pgm``, a folder per map).
    """
    import numpy as np

    for i in range(n):
        j = i % PER_FOLDER
        algo, run = ALGOS[j // 100], j % 100  # <= 2 digits: not a numbered snapshot
        img = np.full((20, 20), 254, np.uint8)
        r = i % 8
        img[2 + r : 12 + r, 5:15] = 0
        if layout == "runs":
            path = root / algo / f"seq{i // PER_FOLDER:03d}" / str(run) / "map.pgm"
        else:
            path = root / f"seq{i // PER_FOLDER:03d}" / f"{algo}_map_{run}.pgm"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(b"P5 20 20 255\n" + img.tobytes())


def peak_rss(args: list[str]) -> tuple[float, float, int]:
    """(peak RSS MiB, seconds, exit code) of ``python -m slamq ARGS``."""
    t0 = time.perf_counter()
    proc = subprocess.Popen([sys.executable, "-m", "slamq", *args],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, ru = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    err = proc.stderr.read().decode() if proc.stderr else ""
    if proc.returncode not in (0,):
        sys.exit(f"slamq {' '.join(args)} exited {proc.returncode}: {err[-2000:]}")
    return ru.ru_maxrss / 1024.0, time.perf_counter() - t0, proc.returncode


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--maps", type=int, nargs="+", default=[2000, 8000])
    ap.add_argument("--formats", nargs="+", default=["jsonl", "parquet"])
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--layout", choices=("flat", "runs"), default="flat")
    a = ap.parse_args()
    rows: dict[tuple[str, str, int], float] = {}
    with tempfile.TemporaryDirectory() as tmp:
        for n in a.maps:
            root = Path(tmp) / f"maps{n}"
            root.mkdir()
            make_maps(root, n, a.layout)
            for fmt in a.formats:
                out = Path(tmp) / f"r{n}.{fmt}"
                for phase in ("fresh", "resume"):
                    mib, sec, _ = peak_rss(["batch", str(root), "--out", str(out), "-q",
                                            "--no-progress", "--threads", str(a.threads)])
                    rows[(fmt, phase, n)] = mib
                    print(f"{fmt:8s} {phase:6s} {n:6d} maps: peak RSS {mib:6.1f} MiB, "
                          f"{sec:5.1f} s", flush=True)
    lo, hi = min(a.maps), max(a.maps)
    if lo != hi:
        for fmt in a.formats:
            for phase in ("fresh", "resume"):
                d = rows[(fmt, phase, hi)] - rows[(fmt, phase, lo)]
                print(f"{fmt:8s} {phase:6s} {lo} -> {hi}: {d:+.1f} MiB, "
                      f"{d * 1024 / (hi - lo):+.2f} KB/map")


if __name__ == "__main__":
    main()
