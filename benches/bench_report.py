"""``slamq report`` and ``slamq summary`` as a user runs them, this build against a base
build in the same minutes (issue 42 point 11).

Cases (each a fresh ``python -m slamq ...`` process, as the user's command):

- ``report 6``: the shipped slam_comparison_tools office world (five SLAM maps with their
  pose logs and the ground-truth map; ``slamq batch tests/data/slam_comparison_tools``),
  into a new folder (``cold``) and again into the same folder (``rerun``).
- ``report N``: N records made from those six (same maps, metrics jittered by +-10 %, one
  sequence per 1,000 maps, the runs numbered), the default options. The base build makes a
  detail page for every map by default (hours at 10,000); it is run with
  ``--details gallery`` there, which this build's default picks above 60 maps.
- ``summary 6``: ``slamq summary`` of the six records.

Each figure is the median of ``--repeat`` rounds, builds alternating; wall time and the
child's CPU time (user + system, ``resource.getrusage(RUSAGE_CHILDREN)``), since the
machine is shared. The base build is any checkout whose ``python/`` holds slamq (with its
``_core`` library)::

    git worktree add --detach /tmp/slamq-base <commit>
    cp python/slamq/_core.abi3.so /tmp/slamq-base/python/slamq/
    PYTHONPATH=python python benches/bench_report.py --base /tmp/slamq-base --maps 1000 10000

Prints one table; every ratio is of figures measured in this run.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

BENCHES = Path(__file__).resolve().parent
REPO = BENCHES.parent


def run(python_path: Path, args: list[str]) -> tuple[float, float]:
    """Wall and CPU seconds of ``python -m slamq ARGS`` with ``python_path`` first."""
    env = {**os.environ, "PYTHONPATH": str(python_path)}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "slamq", *args], env=env,
                          capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise SystemExit(f"slamq {' '.join(args)} failed:\n{done.stderr[-2000:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def office_records(tmp: Path) -> Path:
    """The six records of the shipped office world (``slamq batch``)."""
    out = tmp / "office.jsonl"
    run(REPO / "python", ["batch", str(REPO / "tests" / "data" / "slam_comparison_tools"),
                          "--out", str(out), "-q"])
    return out


def many_records(six: Path, n: int, out: Path) -> Path:
    """``n`` records from the SLAM maps of ``six``, metrics jittered, 1,000 maps a
    sequence."""
    recs = [json.loads(x) for x in six.read_text().splitlines()]
    slam = [r for r in recs if r["algorithm"] != "ground_truth"]
    rng = random.Random(0)
    nseq = max(1, n // 1000)
    with out.open("w") as f:
        for i in range(n):
            rec = dict(slam[i % len(slam)])
            rec["sequence"] = f"world{i // len(slam) % nseq:02d}"
            rec["run"] = str(i // (len(slam) * nseq))
            for k in ("ate_rmse", "corners", "occupied_fraction", "enclosed_areas", "gt_f1",
                      "proportion"):
                if isinstance(rec.get(k), (int, float)):
                    v = rec[k] * (1 + 0.1 * rng.uniform(-1, 1))
                    rec[k] = round(v) if k in ("corners", "enclosed_areas") else v
            f.write(json.dumps(rec) + "\n")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--base", type=Path, help="checkout of the base build (its python/)")
    ap.add_argument("--repeat", type=int, default=3, help="rounds of the small cases")
    ap.add_argument("--maps", type=int, nargs="*", default=[1000],
                    help="sizes of the large reports (one round each)")
    ap.add_argument("--base-max", type=int, default=1000,
                    help="largest report the base build makes (its pages draw with "
                    "matplotlib: minutes a hundred)")
    args = ap.parse_args()
    builds = {"this": REPO / "python"}
    if args.base is not None:
        builds["base"] = args.base / "python"
    tmp = Path(tempfile.mkdtemp(prefix="bench_report_"))
    rows: dict[tuple[str, str], list[tuple[float, float]]] = {}
    try:
        six = office_records(tmp)
        for r in range(args.repeat):
            for name, path in builds.items():
                site = tmp / f"{name}-{r}"
                rows.setdefault(("report 6, cold", name), []).append(
                    run(path, ["report", str(six), "--out", str(site), "-q"]))
                rows.setdefault(("report 6, rerun", name), []).append(
                    run(path, ["report", str(six), "--out", str(site), "-q"]))
                rows.setdefault(("summary 6", name), []).append(
                    run(path, ["summary", str(six)]))
                shutil.rmtree(site)
        for n in args.maps:
            many = many_records(six, n, tmp / f"many{n}.jsonl")
            for name, path in builds.items():
                if name == "base" and n > args.base_max:
                    continue
                extra = ["--details", "gallery"] if name == "base" else []
                site = tmp / f"{name}-{n}"
                rows.setdefault((f"report {n}", name), []).append(
                    run(path, ["report", str(many), "--out", str(site), "-q", *extra]))
                if name == "this":
                    pages = len(list((site / "maps").glob("*.html")))
                    print(f"report {n}: {pages} detail pages", flush=True)
                shutil.rmtree(site)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    load = os.getloadavg()
    print(f"\nload average {load[0]:.1f} {load[1]:.1f} {load[2]:.1f} on {os.cpu_count()} "
          f"cores; medians of {args.repeat} rounds (one for the large reports)\n")
    print("| case | base wall s | base CPU s | this wall s | this CPU s | CPU speed-up |")
    print("|---|---:|---:|---:|---:|---:|")
    for case in dict.fromkeys(c for c, _ in rows):
        med = {b: (statistics.median(w for w, _ in rows[(case, b)]),
                   statistics.median(c for _, c in rows[(case, b)]))
               for b in builds if (case, b) in rows}
        base = med.get("base", (float("nan"), float("nan")))
        this = med["this"]
        ratio = base[1] / this[1] if this[1] > 0 else float("nan")
        print(f"| {case} | {base[0]:.2f} | {base[1]:.2f} | {this[0]:.2f} | {this[1]:.2f} "
              f"| {ratio:.2f}x |")


if __name__ == "__main__":
    main()
