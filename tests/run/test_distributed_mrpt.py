"""The MRPT example (rbpf-slam with 5 and 20 particles, icp-slam; seeded by the iteration)
on a 2-worker Dask cluster of processes gives the same run keys, maps and numbers as the
local run. On the last 50 steps of MRPT's dataset and 2 iterations, to stay short
(benches/bench_run_dask_mrpt.py runs the whole example, with a worker killed 10 s in)."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
import yaml
from _daskproc import Cluster, available

from slamq.results import read_results
from slamq.runner import runner
from slamq.runner.distributed import dask_backend
from slamq.sources import load_map

DATASET = Path("/usr/share/mrpt/datasets/2006-01ENE-21-SENA_Telecom Faculty_one_loop_only.rawlog")
EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "mrpt.yaml"

pytestmark = pytest.mark.skipif(
    not available() or not all(shutil.which(p) for p in ("rbpf-slam", "icp-slam", "rawlog-edit"))
    or not DATASET.exists(),
    reason="dask.distributed, MRPT programs or dataset absent",
)


def _numbers(out: Path) -> list[tuple]:
    df = read_results(out / "results.jsonl").sort_values(["algorithm", "run"])
    cols = [c for c in ("algorithm", "run", "known", "occupied", "corners", "enclosed_areas",
                        "occupied_fraction") if c in df]
    return [tuple(r) for r in df[cols].itertuples(index=False)]


def test_mrpt_example_on_two_dask_workers_equals_the_local_run(tmp_path: Path) -> None:
    short = tmp_path / "short.rawlog"
    subprocess.run(["rawlog-edit", "--cut", "--from-index", "349", "-i", str(DATASET),
                    "-o", str(short)], check=True, capture_output=True,
                   stdin=subprocess.DEVNULL, timeout=60)
    cfg = yaml.safe_load(EXAMPLE.read_text())
    cfg.update(sequences={"telecom_tail": {"input": str(short)}}, output=str(tmp_path / "runs"),
               base_dir=str(tmp_path), timeout=120, report=False,
               iterations=2)  # 6 runs: the test stays short (the bench runs all 9, in full)
    with pytest.warns(UserWarning, match="different resolutions"):
        local = runner.run(cfg)
    assert [r["outcome"] for r in local["rows"]] == ["ok"] * 6
    want = _numbers(tmp_path / "runs")
    maps = {r["key"]: load_map(r["map"]) for r in local["rows"]}
    shutil.move(tmp_path / "runs", tmp_path / "local")
    cluster = Cluster(tmp_path / "dask")
    try:
        cluster.add_worker("w1")
        cluster.add_worker("w2")
        with pytest.warns(UserWarning, match="different resolutions"):
            dist = runner.run(cfg, backend=dask_backend(cluster.address))
    finally:
        cluster.close()
    assert sorted((r["algorithm"], r["iteration"], r["key"]) for r in dist["rows"]) == \
        sorted((r["algorithm"], r["iteration"], r["key"]) for r in local["rows"])
    assert all(r["outcome"] == "ok" and r["max_rss_kb"] > 10_000 for r in dist["rows"])
    for r in dist["rows"]:  # the same maps, cell for cell
        a, b = maps[r["key"]], load_map(r["map"])
        assert a.values.shape == b.values.shape and np.array_equal(a.values, b.values)
        assert a.origin == b.origin
    assert _numbers(tmp_path / "runs") == want
    # the particle filter still differs between iterations (the seed is the iteration)
    occ = {(n[0], n[1]): n[3] for n in want}
    assert len({occ[("rbpf-slam[particles=5]", str(i))] for i in (1, 2)}) > 1
