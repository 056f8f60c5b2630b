"""Wall time of a rerun of ``slamq run examples/mrpt.yaml`` with nothing left to run.

Target (issue 27): <= 5 s, from 17 s. The example's 9 runs (rbpf-slam 5 and 20 particles,
icp-slam, 3 iterations, MRPT's Telecom dataset; needs ``mrpt-apps``) are run once into a
temporary folder; then, on that same folder, each in a fresh ``slamq run`` process:

- ``baseline``: the rerun of slamq at ``--baseline REV`` (default ``3e957b6``, before
  issue 27): its Python sources from ``git archive`` with this build's Rust core, so the
  same folder is scored by both. It re-evaluates the maps for the report, redraws every
  detail page and rewrites the report.
- ``after baseline``: this slamq's rerun right after a baseline one, which rewrote
  ``runs.csv``, ``scores.csv``, the summary and the report: what it rewrote with the same
  content counts as unchanged (the stamps are digests of content); an ``index.html`` that
  differs from the one this slamq wrote (the report's date) makes it write the index
  again, keeping every detail page.
- ``nothing changed``: this slamq's rerun right after one of its own: nothing scored,
  drawn or written.
- ``one map changed`` (once, at the end): one run's map image gets a wall more: that map
  is scored again, its detail page and the index redrawn.

The orders alternate over ``--repeat`` rounds; wall and CPU (the child's user + system)
are printed per mode (median), with the load average beside them, and the ratio to the
baseline measured in the same run.

    PYTHONPATH=python python benches/bench_rerun.py                 # 2 rounds
    PYTHONPATH=python python benches/bench_rerun.py --repeat 3 --keep /tmp/rerun-bench
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml

REPO = Path(__file__).resolve().parent.parent
EXAMPLE = REPO / "examples" / "mrpt.yaml"


def _baseline(rev: str, where: Path) -> Path:
    """This repository's ``python/`` at ``rev``, with the Rust core of this build."""
    import slamq._core as core

    where.mkdir(parents=True, exist_ok=True)
    archive = subprocess.run(["git", "-C", str(REPO), "archive", rev, "python"],
                             check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(where)], input=archive, check=True)
    shutil.copy(core.__file__, where / "python" / "slamq" / Path(core.__file__).name)
    return where / "python"


def _slamq(config: Path, pythonpath: str) -> tuple[float, float, str]:
    """``slamq run CONFIG`` in a fresh process: wall s, CPU s of the child, its stdout."""
    env = dict(os.environ, PYTHONPATH=pythonpath, PYTHONDONTWRITEBYTECODE="1")
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "slamq", "run", str(config)], env=env,
                          capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        sys.exit(f"slamq run failed ({proc.returncode}):\n{proc.stderr[-2000:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu, proc.stdout


def _load() -> float:
    return os.getloadavg()[0]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--baseline", default="3e957b6", help="git revision to compare with")
    ap.add_argument("--keep", type=Path, help="work folder to keep (default: a temporary one)")
    args = ap.parse_args()
    if not shutil.which("rbpf-slam"):
        sys.exit("needs mrpt-apps (rbpf-slam, icp-slam)")
    work = args.keep or Path(tempfile.mkdtemp(prefix="slamq-rerun-"))
    work.mkdir(parents=True, exist_ok=True)
    cfg = yaml.safe_load(EXAMPLE.read_text())
    cfg["output"] = str(work / "runs")
    config = work / "mrpt.yaml"
    config.write_text(yaml.safe_dump(cfg))
    here = str(REPO / "python")
    base = str(_baseline(args.baseline, work / "baseline"))
    times: dict[str, list[tuple[float, float, float]]] = {}

    def timed(mode: str, path: str) -> str:
        load = _load()
        wall, cpu, out = _slamq(config, path)
        times.setdefault(mode, []).append((wall, cpu, load))
        print(f"  {mode:<18} wall {wall:6.2f} s  cpu {cpu:6.2f} s  load {load:.1f}",
              file=sys.stderr)
        return out

    print(f"first run into {work / 'runs'} (9 MRPT runs)...", file=sys.stderr)
    timed("first run", here)
    for i in range(args.repeat):
        if i % 2 == 0:
            timed("nothing changed", here)
            timed("baseline", base)
            timed("after baseline", here)
            timed("nothing changed", here)
        else:
            timed("baseline", base)
            timed("after baseline", here)
            timed("nothing changed", here)
    # one map gets a wall more: scored again, its page and the index redrawn
    import cv2

    png = next((work / "runs" / "icp-slam").glob("default/*/1/out/_finalmaps_*.png"))
    img = cv2.imread(str(png), cv2.IMREAD_UNCHANGED)
    img[10:13, 10:60] = 0
    cv2.imwrite(str(png), img)
    out = timed("one map changed", here)
    print("\n".join("  | " + line for line in out.splitlines()
                    if line.startswith(("scores:", "GIFs:", "report"))), file=sys.stderr)

    base_wall = statistics.median(w for w, _, _ in times["baseline"])
    print(f"\n`slamq run examples/mrpt.yaml` reruns, median of each mode's runs "
          f"(baseline = {args.baseline}):\n")
    print("| mode | runs | wall s | CPU s | load | wall x baseline |")
    print("|---|---|---|---|---|---|")
    for mode, rows in times.items():
        wall = statistics.median(w for w, _, _ in rows)
        cpu = statistics.median(c for _, c, _ in rows)
        load = statistics.median(x for _, _, x in rows)
        ratio = "" if mode == "first run" else f"{wall / base_wall:.2f}"
        print(f"| {mode} | {len(rows)} | {wall:.2f} | {cpu:.2f} | {load:.1f} | {ratio} |")
    stages = [json.loads(x) for x in (work / "runs" / "stages.jsonl").read_text().splitlines()]
    print(f"\nlast stages: {[(s['stage'], s['done'], s['skipped']) for s in stages[-3:]]}")
    if args.keep is None:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
