"""slamq run on Kubernetes through Dask (dask-kubernetes' operator): a DaskCluster whose
worker pods each run ``slots`` SLAM programs at once.

    pip install 'slamq[dask]' dask-kubernetes     # the Dask operator must be installed
    python examples/distributed/slamq_dask_kubernetes.py run.yaml --image IMAGE --workers 8

The image holds slamq and the SLAM programs; the worker pods need the sequences' inputs at
the config's paths (in the image, or a volume added to the spec). Without a shared volume
for the output folder the workers send each run folder back to this client
(``outputs="auto"`` decides per worker), which writes them and scores them here.
"""

from __future__ import annotations

import argparse
from typing import Any


def cluster_spec(name: str, image: str, workers: int = 4, slots: int = 1) -> dict[str, Any]:
    """The DaskCluster resource: workers with ``slamq_run=SLOTS`` and SLOTS threads, and
    two cores per slot."""
    from dask_kubernetes.operator import make_cluster_spec

    spec = make_cluster_spec(name=name, image=image, n_workers=workers,
                             resources={"requests": {"cpu": str(2 * slots), "memory": "2Gi"},
                                        "limits": {"memory": f"{4 * slots}Gi"}})
    worker = spec["spec"]["worker"]["spec"]["containers"][0]
    worker["args"] = [*worker["args"], "--nthreads", str(slots),
                      "--resources", f"slamq_run={slots}"]
    return spec


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("config")
    ap.add_argument("--image", required=True)
    ap.add_argument("--workers", type=int, default=4)
    ap.add_argument("--slots", type=int, default=1)
    args = ap.parse_args()

    from dask_kubernetes.operator import KubeCluster
    from distributed import Client

    import slamq
    from slamq.runner.distributed import dask_backend

    cluster = KubeCluster(custom_cluster_spec=cluster_spec("slamq", args.image, args.workers,
                                                           args.slots))
    try:
        with Client(cluster) as client:
            result = slamq.run(args.config, backend=dask_backend(client))
    finally:
        cluster.close()
    print(f"report: {result['report']}")


if __name__ == "__main__":
    main()
