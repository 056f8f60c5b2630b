"""slamq run on a Slurm cluster through Dask (dask-jobqueue): one Slurm job per Dask worker.

    pip install 'slamq[dask]' dask-jobqueue
    python examples/distributed/slamq_dask_slurm.py run.yaml --jobs 8 --slots 1

Each worker job asks for ``2 * slots`` cores (as many Dask threads) and declares
``slamq_run=SLOTS``, so it runs at most SLOTS SLAM programs at once. The client runs where you start
this script (a login node): it plans, skips finished runs, receives the results and scores
them. With the output folder on the shared filesystem the workers write the run folders
there; without it they send them back (``outputs="auto"``). A worker job that ends (its
walltime, preemption) loses its runs to the other workers; rerunning this script resumes.
"""

from __future__ import annotations

import argparse
from typing import Any


def make_cluster(jobs: int = 4, slots: int = 1, memory: str = "8GB",
                 walltime: str = "04:00:00", **kwargs: Any) -> Any:
    """A dask-jobqueue ``SLURMCluster`` whose workers each run ``slots`` runs at once."""
    from dask_jobqueue import SLURMCluster

    cluster = SLURMCluster(
        cores=2 * slots, processes=1, memory=memory, walltime=walltime,
        worker_extra_args=["--resources", f"slamq_run={slots}"],
        **kwargs)
    cluster.scale(jobs=jobs)
    return cluster


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("config")
    ap.add_argument("--jobs", type=int, default=4)
    ap.add_argument("--slots", type=int, default=1)
    ap.add_argument("--queue", default=None, help="Slurm partition")
    args = ap.parse_args()

    from distributed import Client

    import slamq
    from slamq.runner.distributed import dask_backend

    cluster = make_cluster(args.jobs, args.slots, queue=args.queue)
    with Client(cluster) as client:
        result = slamq.run(args.config, backend=dask_backend(client))
    cluster.close()
    print(f"report: {result['report']}")


if __name__ == "__main__":
    main()
