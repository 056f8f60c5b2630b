"""The MRPT example locally and on a 2-worker Dask cluster of processes, with one worker
killed 10 s into the Dask run (targets of "Runs across machines").

examples/mrpt.yaml on MRPT's full Telecom dataset (rbpf-slam 5 and 20 particles, icp-slam;
3 iterations seeded by the iteration): once with local slots (``parallel: 2``), once on a
loopback cluster (``dask scheduler`` + two ``dask worker`` processes, one slot each) whose
first worker's process group gets SIGKILL ``--kill-after`` seconds after the client starts.
Prints: runs recorded, distinct run keys, duplicate records, SLAM processes left behind,
whether every map (cell for cell) and every number equals the local run's, and the walls.

    PYTHONPATH=python python benches/bench_run_dask_mrpt.py            # ~3 minutes
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import signal
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np
import yaml

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "benches"))

from bench_run_dask import _start, _stop  # noqa: E402


def _slam_left(root: Path) -> list[int]:
    left = []
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            cwd = os.readlink(d / "cwd")
            comm = (d / "comm").read_text().strip()
        except OSError:
            continue
        if cwd.startswith(str(root)) and comm in ("rbpf-slam", "icp-slam"):
            left.append(int(d.name))
    return left


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--kill-after", type=float, default=10.0)
    args = ap.parse_args()

    from distributed import Client

    from slamq.results import read_results
    from slamq.runner import runner
    from slamq.runner.distributed import dask_backend
    from slamq.sources import load_map

    tmp = Path(tempfile.mkdtemp(prefix="slamq-bench-mrpt-"))
    cfg = yaml.safe_load((REPO / "examples" / "mrpt.yaml").read_text())
    cfg.update(output=str(tmp / "runs"), base_dir=str(tmp), report=False)
    t0 = time.perf_counter()
    local = runner.run(cfg)
    local_wall = time.perf_counter() - t0
    maps = {r["key"]: load_map(r["map"]) for r in local["rows"]}
    cols = ["algorithm", "run", "known", "occupied", "corners", "enclosed_areas"]
    want = read_results(tmp / "runs" / "results.jsonl").sort_values(["algorithm", "run"])[cols]
    shutil.move(tmp / "runs", tmp / "local")

    file = tmp / "scheduler.json"
    procs = [_start(["scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                     "--scheduler-file", str(file)], tmp / "scheduler.log")]
    try:
        while not file.exists() or not file.read_text().strip():
            time.sleep(0.05)
        address = json.loads(file.read_text())["address"]
        for i in range(2):
            procs.append(_start(["worker", address, "--nworkers", "1", "--nthreads", "1",
                                 "--no-dashboard", "--host", "127.0.0.1", "--name", f"w{i}"],
                                tmp / f"w{i}.log"))
        with Client(address, timeout=30) as c:
            c.wait_for_workers(2, timeout=60)
        killed_at: list[float] = []

        def kill() -> None:
            time.sleep(args.kill_after)
            os.killpg(procs[1].pid, signal.SIGKILL)
            killed_at.append(time.perf_counter() - t0)

        t0 = time.perf_counter()
        threading.Thread(target=kill, daemon=True).start()
        dist = runner.run(cfg, backend=dask_backend(address))
        dask_wall = time.perf_counter() - t0
        time.sleep(3)
        left = _slam_left(tmp)
    finally:
        for p in reversed(procs):
            _stop(p)
    rows = dist["rows"]
    got = read_results(tmp / "runs" / "results.jsonl").sort_values(["algorithm", "run"])[cols]
    same_maps = all(np.array_equal(maps[r["key"]].values, load_map(r["map"]).values)
                    for r in rows)
    records = list((tmp / "runs").glob("*/*/*/*/run.json"))
    print(f"MRPT example, full dataset, 9 runs; worker w0 killed at {killed_at[0]:.1f} s "
          f"(load {os.getloadavg()[0]:.1f})")
    print(f"local (2 slots)         wall {local_wall:6.1f} s")
    print(f"dask (2 workers, kill)  wall {dask_wall:6.1f} s")
    print(f"outcomes: {sorted(r['outcome'] for r in rows)}")
    print(f"run.json records {len(records)}, distinct keys {len({r['key'] for r in rows})}, "
          f"results rows {len(got)}, duplicate results "
          f"{int(got.duplicated(['algorithm', 'run']).sum())}")
    print(f"SLAM processes left behind: {left}")
    print(f"maps equal to local, cell for cell: {same_maps}; numbers equal: "
          f"{got.reset_index(drop=True).equals(want.reset_index(drop=True))}")
    shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
