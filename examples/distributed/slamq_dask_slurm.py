"""slamq run on a Slurm cluster through Dask (dask-jobqueue): one Slurm job per Dask worker.

    pip install 'slamq[dask]' dask-jobqueue
    python examples/distributed/slamq_dask_slurm.py run.yaml --jobs 8 --slots 1

Each worker job asks for ``slots * cores_per_run`` cores (as many Dask threads) and
declares ``slamq_run=SLOTS``, so it runs at most SLOTS SLAM programs at once. Before
submitting, the script checks that some node of the partition has that many cores and that
much memory (``sinfo``), and refuses otherwise instead of waiting for jobs that can never
start; it also gives up, naming the jobs' state, when no worker has joined after
``--start-timeout`` seconds. The client runs where you start this script (a login node): it
plans, skips finished runs, receives the results and scores them; slamq must be importable
in the workers' environment too (the jobs inherit this shell's environment). With the
output folder on the shared filesystem the workers write the run folders there; without it
they send them back (``outputs="auto"``). A worker job that ends (its walltime, preemption)
loses its runs to the other workers; rerunning this script resumes.

``--interface`` is the network interface the scheduler and workers listen on (default: the
one dask-jobqueue picks, the first non-loopback one; a single machine needs ``lo``). Prints
one line: the runs by outcome, the time, the report.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import time
import warnings
from typing import Any


def node_capacity(queue: str | None = None) -> tuple[int, int]:
    """The largest (CPUs, memory in MB) of one node of the partition, from ``sinfo``."""
    cmd = ["sinfo", "-h", "-N", "-o", "%c %m"] + (["-p", queue] if queue else [])
    out = subprocess.run(cmd, capture_output=True, text=True, check=True, timeout=30).stdout
    cpus = mem = 0
    for line in out.splitlines():
        parts = line.split()
        if len(parts) == 2 and parts[0].isdigit():
            cpus = max(cpus, int(parts[0]))
            size = parts[1].rstrip("+")
            mem = max(mem, int(size) if size.isdigit() else 0)
    return cpus, mem


def _megabytes(memory: str) -> int:
    from dask.utils import parse_bytes

    return int(parse_bytes(memory) / 1e6)


def check_request(slots: int, cores_per_run: int, memory: str,
                  queue: str | None = None) -> int:
    """The cores one worker job asks for, or SystemExit(2) when no node can give them."""
    cores = slots * cores_per_run
    if shutil.which("sinfo") is None:
        return cores  # not on a Slurm login node: let Slurm answer
    cpus, mem = node_capacity(queue)
    where = f"partition {queue}" if queue else "the default partition"
    if cores > cpus:
        raise SystemExit(f"slamq_dask_slurm: --slots {slots} x {cores_per_run} cores per run "
                         f"= {cores} cores per job, but no node of {where} has more than "
                         f"{cpus}: lower --slots or --cores-per-run")
    if mem and _megabytes(memory) > mem:
        raise SystemExit(f"slamq_dask_slurm: --memory {memory} per job, but no node of {where} "
                         f"has more than {mem} MB: lower --memory")
    return cores


def make_cluster(jobs: int = 4, slots: int = 1, memory: str = "8GB",
                 walltime: str = "04:00:00", cores_per_run: int = 2,
                 **kwargs: Any) -> Any:
    """A dask-jobqueue ``SLURMCluster`` whose workers each run ``slots`` runs at once."""
    from dask_jobqueue import SLURMCluster

    cluster = SLURMCluster(
        cores=slots * cores_per_run, processes=1, memory=memory, walltime=walltime,
        worker_extra_args=["--resources", f"slamq_run={slots}"],
        **{k: v for k, v in kwargs.items() if v is not None})
    cluster.scale(jobs=jobs)
    return cluster


def _job_states(cluster: Any) -> str:
    ids = [j.job_id for j in list(cluster.workers.values()) if getattr(j, "job_id", None)]
    if not ids or shutil.which("squeue") is None:
        return "no job id known"
    out = subprocess.run(["squeue", "-h", "-j", ",".join(ids), "-o", "%i %T %r"],
                         capture_output=True, text=True, timeout=30).stdout.strip()
    return out.replace("\n", "; ") or "the jobs have ended"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("config")
    ap.add_argument("--jobs", type=int, default=4, help="worker jobs (default 4)")
    ap.add_argument("--slots", type=int, default=1, help="runs at once per job (default 1)")
    ap.add_argument("--cores-per-run", type=int, default=2,
                    help="cores a SLAM run may use (default 2)")
    ap.add_argument("--memory", default="8GB", help="memory per job (default 8GB)")
    ap.add_argument("--walltime", default="04:00:00", help="time limit per job")
    ap.add_argument("--queue", default=None, help="Slurm partition")
    ap.add_argument("--account", default=None, help="Slurm account to charge")
    ap.add_argument("--interface", default=None,
                    help="network interface for the scheduler and workers (e.g. ib0, lo)")
    ap.add_argument("--start-timeout", type=float, default=600.0,
                    help="seconds to wait for the first worker before giving up")
    args = ap.parse_args(argv)

    from distributed import Client

    import slamq
    from slamq.runner.distributed import dask_backend

    check_request(args.slots, args.cores_per_run, args.memory, args.queue)
    started = time.monotonic()
    caught: list[str] = []
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        cluster = make_cluster(args.jobs, args.slots, args.memory, args.walltime,
                               args.cores_per_run, queue=args.queue, account=args.account,
                               interface=args.interface)
        try:
            with Client(cluster) as client:
                try:
                    client.wait_for_workers(1, timeout=args.start_timeout)
                except TimeoutError:
                    print(f"slamq_dask_slurm: no worker joined in {args.start_timeout:.0f} s "
                          f"({_job_states(cluster)}); check the partition, account and "
                          "--interface", file=sys.stderr)
                    return 2
                result = slamq.run(args.config, backend=dask_backend(client))
        finally:
            cluster.close()
        caught = sorted({f"{w.category.__name__}: {w.message}" for w in seen})
    for text in caught:
        print(f"slamq_dask_slurm: warning: {' '.join(text.split())}", file=sys.stderr)
    counts: dict[str, int] = {}
    for row in result["rows"]:
        counts[row["outcome"]] = counts.get(row["outcome"], 0) + 1
    ran = sum(not r.get("skipped") for r in result["rows"])
    print(f"slamq: {len(result['rows'])} runs ("
          + ", ".join(f"{n} {k}" for k, n in sorted(counts.items()))
          + f"; ran {ran}) in {time.monotonic() - started:.0f} s on {args.jobs} Slurm job(s); "
          f"report: {result['report']}")
    return 0 if counts.keys() <= {"ok"} else 3


if __name__ == "__main__":
    sys.exit(main())
