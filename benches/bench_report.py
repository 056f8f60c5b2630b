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

Each figure is the minimum over ``--repeat`` rounds (the medians are printed too), builds
alternating, after one warm-up round that is not counted; wall time and the child's CPU
time (user + system, ``resource.getrusage(RUSAGE_CHILDREN)``), since the machine is
shared. The children write and read compiled bytecode (``PYTHONPYCACHEPREFIX`` in the
temporary folder, ``PYTHONDONTWRITEBYTECODE`` unset), as an installed package has it:
without it every run compiles slamq's modules again (about 0.5 s of CPU for a report).
The table gives each case's target (issue 42 point 11: a 6-map report <= 3 s, 10,000 maps
<= 5 min, ``slamq summary`` of 6 rows <= 0.5 s) and the ratio of this build's figures to
it. The base build is any checkout whose ``python/`` holds slamq (with its ``_core``
library)::

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


#: The targets of issue 42 point 11, seconds (None: no target).
TARGETS: dict[str, float] = {"report 6, cold": 3.0, "report 6, rerun": 3.0, "summary 6": 0.5,
                             "report 10000": 300.0}
#: Where the children keep compiled bytecode (set in main).
PYCACHE: dict[str, str] = {}


def run(python_path: Path, args: list[str]) -> tuple[float, float]:
    """Wall and CPU seconds of ``python -m slamq ARGS`` with ``python_path`` first."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env["PYTHONPATH"] = str(python_path)
    env.update(PYCACHE)
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
    ap.add_argument("--repeat", type=int, default=5, help="rounds of the small cases")
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
    PYCACHE["PYTHONPYCACHEPREFIX"] = str(tmp / "pycache")
    rows: dict[tuple[str, str], list[tuple[float, float]]] = {}
    load0 = os.getloadavg()
    try:
        six = office_records(tmp)
        for r in range(-1, args.repeat):  # round -1 compiles the bytecode: not counted
            for name, path in builds.items():
                site = tmp / f"{name}-{r}"
                got = {
                    "report 6, cold": run(path, ["report", str(six), "--out", str(site),
                                                 "-q"]),
                    "report 6, rerun": run(path, ["report", str(six), "--out", str(site),
                                                  "-q"]),
                    "summary 6": run(path, ["summary", str(six)]),
                }
                shutil.rmtree(site)
                if r >= 0:
                    for case, t in got.items():
                        rows.setdefault((case, name), []).append(t)
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
    print(f"\nload average {load0[0]:.1f} {load0[1]:.1f} {load0[2]:.1f} at the start, "
          f"{load[0]:.1f} {load[1]:.1f} {load[2]:.1f} at the end, on {os.cpu_count()} "
          f"cores; minimum (median) of {args.repeat} rounds, one for the large reports\n")
    print("| case | target s | base wall s | base CPU s | this wall s | this CPU s "
          "| this CPU / target | this wall / target | CPU speed-up |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    nan = float("nan")

    def fig(times: list[tuple[float, float]] | None, i: int) -> tuple[float, str]:
        if not times:
            return nan, "-"
        values = [t[i] for t in times]
        low = min(values)
        if len(values) == 1:
            return low, f"{low:.2f}"
        return low, f"{low:.2f} ({statistics.median(values):.2f})"

    for case in dict.fromkeys(c for c, _ in rows):
        target = TARGETS.get(case)
        bw, bw_text = fig(rows.get((case, "base")), 0)
        bc, bc_text = fig(rows.get((case, "base")), 1)
        tw, tw_text = fig(rows.get((case, "this")), 0)
        tc, tc_text = fig(rows.get((case, "this")), 1)
        per = (f"{tc / target:.2f}", f"{tw / target:.2f}") if target else ("-", "-")
        speed = f"{bc / tc:.2f}x" if tc > 0 and bc == bc else "-"
        print(f"| {case} | {target if target else '-'} | {bw_text} | {bc_text} | {tw_text} "
              f"| {tc_text} | {per[0]} | {per[1]} | {speed} |")


if __name__ == "__main__":
    main()
