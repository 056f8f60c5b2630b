"""Scheduling overhead of ``slamq run --scheduler`` against local slots.

Target ("Runs across machines"): <= 0.2 s of scheduling overhead per run. 200 runs of a
trivial command (``sh -c`` writing a 4 x 4 ASCII PGM map, collected and checked like any
map; no scoring) with two slots: locally (``parallel: 2``, threads of this process) and on
a Dask cluster of real processes on 127.0.0.1 (``dask scheduler`` + two ``dask worker``
processes of one thread each, started before the clock; the client's connection is timed),
in both output modes (``shared``: the worker writes the run folder; ``return``: it sends the
folder back as a tar the client unpacks). The orders alternate over ``--repeat`` rounds.

Overhead per run = (wall on Dask - wall locally) x slots / runs: the time each run's slot
spends on Dask's side of the run (submission, scheduling, result transfer), on top of the
run itself.

    PYTHONPATH=python python benches/bench_run_dask.py              # 200 runs, 2 rounds
    PYTHONPATH=python python benches/bench_run_dask.py --runs 50    # quicker

Prints a table; each ratio is computed from numbers measured in the same run.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
MAP = "printf 'P2\\n4 4\\n255\\n0 0 0 0\\n254 254 254 254\\n254 254 254 254\\n0 0 0 0\\n' > map.pgm"


def _start(args: list[str], log: Path) -> subprocess.Popen:
    dask = str(Path(sys.executable).with_name("dask"))
    return subprocess.Popen([dask, *args], stdout=subprocess.DEVNULL, stderr=open(log, "w"),
                            stdin=subprocess.DEVNULL, start_new_session=True)


def _stop(p: subprocess.Popen) -> None:
    for sig in (signal.SIGTERM, signal.SIGKILL):
        try:
            os.killpg(p.pid, sig)
        except ProcessLookupError:
            return
        try:
            p.wait(timeout=5)
            return
        except subprocess.TimeoutExpired:
            continue


def _cluster(folder: Path, workers: int) -> tuple[str, list[subprocess.Popen]]:
    from distributed import Client

    file = folder / "scheduler.json"
    procs = [_start(["scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                     "--scheduler-file", str(file)], folder / "scheduler.log")]
    while not file.exists() or not file.read_text().strip():
        time.sleep(0.05)
    address = json.loads(file.read_text())["address"]
    for i in range(workers):
        procs.append(_start(["worker", address, "--nworkers", "1", "--nthreads", "1",
                             "--no-dashboard", "--host", "127.0.0.1", "--name", f"w{i}"],
                            folder / f"w{i}.log"))
    with Client(address, timeout=30) as c:
        c.wait_for_workers(workers, timeout=60)
    return address, procs


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=200)
    ap.add_argument("--slots", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=2)
    args = ap.parse_args()

    from slamq.runner import runner
    from slamq.runner.distributed import dask_backend

    tmp = Path(tempfile.mkdtemp(prefix="slamq-bench-run-"))
    (tmp / "in.txt").write_text("x\n")
    cfg = {"base_dir": str(tmp), "output": "out", "iterations": args.runs, "report": False,
           "parallel": args.slots, "grace": [0.5, 0.5], "sequences": {"s": "in.txt"},
           "algorithms": {"trivial": {"command": MAP, "outputs": {
               "map": {"path": "map.pgm", "format": "image"}}}}}
    address, procs = _cluster(tmp, args.slots)
    walls: dict[str, list[float]] = {"local": [], "dask shared": [], "dask return": []}
    try:
        for r in range(args.repeat):
            order = list(walls) if r % 2 == 0 else list(reversed(walls))
            for mode in order:
                shutil.rmtree(tmp / "out", ignore_errors=True)
                backend = None if mode == "local" else dask_backend(address, mode.split()[1])
                t0 = time.perf_counter()
                rows = runner.execute(cfg, backend=backend)
                walls[mode].append(time.perf_counter() - t0)
                bad = [x for x in rows if x["outcome"] != "ok"]
                assert len(rows) == args.runs and not bad, bad[:3]
    finally:
        for p in reversed(procs):
            _stop(p)
        shutil.rmtree(tmp, ignore_errors=True)
    local = min(walls["local"])
    print(f"{args.runs} runs of a trivial command, {args.slots} slots, best of {args.repeat} "
          f"(load {os.getloadavg()[0]:.1f})")
    print(f"{'mode':<12} {'wall s':>8} {'runs/s':>8} {'x local':>8} {'overhead/run s':>15}")
    for mode, ws in walls.items():
        w = min(ws)
        over = (w - local) * args.slots / args.runs
        print(f"{mode:<12} {w:8.2f} {args.runs / w:8.1f} {w / local:8.2f} "
              f"{over if mode != 'local' else 0:15.3f}")


if __name__ == "__main__":
    main()
