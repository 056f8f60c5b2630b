"""slamq.batch on a real Dask cluster: 2 worker processes on loopback, same records as local."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from conftest import slamq_env  # noqa: E402

from slamq.batch import evaluate_many
from slamq.cli import main as cli_main
from slamq.results import read_results

distributed = pytest.importorskip("distributed")

from test_batch import needs_core, room, write_map  # noqa: E402


def _strip(recs: list[dict]) -> list[dict]:
    return [{k: v for k, v in r.items() if k != "seconds"} for r in recs]


@needs_core
def test_local_cluster_equals_local(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    root = tmp_path / "runs"
    for i in range(9):
        write_map(root / ("gmapping", "karto", "hector")[i % 3] / "hall" / f"r{i}" / "map",
                  room(48, seed=i, walls=5))
    bad = root / "karto" / "hall" / "r4" / "map.pgm"
    bad.write_bytes(b"P5 48 48 255\n" + b"\x00" * 10)  # truncated: an error row, not a crash
    local = list(evaluate_many(root, threads=2, chunk_size=2))
    assert sum(r["error"] is not None for r in local) == 1

    # the worker processes import the same slamq as this process
    monkeypatch.setenv("PYTHONPATH", slamq_env()["PYTHONPATH"])
    cluster = distributed.LocalCluster(
        n_workers=2, processes=True, threads_per_worker=1, host="127.0.0.1",
        dashboard_address=None,
    )
    try:
        with distributed.Client(cluster) as client:
            out = tmp_path / "r.parquet"
            remote = list(evaluate_many(root, executor=client, chunk_size=2, out=out))
            pids = client.run(os.getpid)
            assert len(set(pids.values())) == 2 and os.getpid() not in pids.values()
            assert _strip(remote) == _strip(local)
            assert read_results(out)["map"].tolist() == [r["map"] for r in local]
            # resumed on the cluster: only the failed map is tried again
            retried = list(evaluate_many(root, executor=client, chunk_size=2, out=out))
            assert [r["map"] for r in retried] == [str(bad.with_suffix(".yaml"))]
            assert len(read_results(out)) == len(local)
            # a scheduler address works as well as a Client
            again = list(evaluate_many(root, executor=cluster.scheduler_address, chunk_size=4))
            assert _strip(again) == _strip(local)
            # and the CLI: DASK_SCHEDULER_ADDRESS sends the batch to the cluster
            monkeypatch.setenv("DASK_SCHEDULER_ADDRESS", cluster.scheduler_address)
            cli_out = tmp_path / "cli.jsonl"
            rc = cli_main(["batch", str(root), "-o", str(cli_out), "--no-progress", "-q"])
            assert rc == 2  # the truncated map
            got = read_results(cli_out)["corners"].dropna().astype(int).tolist()
            assert got == [r["corners"] for r in local if r["error"] is None]
    finally:
        cluster.close()
