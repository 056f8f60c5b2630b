"""The README's "More than one machine" recipes, as far as this machine allows: the Slurm
array script and the Kubernetes Indexed Job's commands run here as their schedulers would
run them (the array / index environment set), then merged; the dask-jobqueue and
dask-kubernetes recipes build their worker job script / cluster spec (no cluster here)."""

from __future__ import annotations

import csv
import importlib.util
import subprocess
from pathlib import Path

import pytest
import yaml
from conftest import slamq_env

RECIPES = Path(__file__).resolve().parents[2] / "examples" / "distributed"


def _config(tmp: Path) -> Path:
    (tmp / "in.txt").write_text("x\n")
    p = tmp / "run.yaml"
    p.write_text(yaml.safe_dump({
        "output": "out", "iterations": 3, "report": False, "sequences": {"s": "in.txt"},
        "algorithms": {"a": {"command": f"echo {{iteration}} >> {tmp / 'ran.txt'}"},
                       "b": {"command": ["true"], "params": {"k": [1, 2]}}}}))
    return p


def _merged(tmp: Path, config: Path) -> list[dict]:
    p = subprocess.run(["slamq", "run", str(config), "--merge"], capture_output=True, text=True,
                       env=slamq_env(), timeout=60)
    assert p.returncode == 0, p.stderr
    with open(tmp / "out" / "runs.csv") as f:
        return list(csv.DictReader(f))


def test_the_slurm_array_script_runs_one_shard_per_task(tmp_path: Path) -> None:
    config = _config(tmp_path)
    procs = [subprocess.Popen(["bash", str(RECIPES / "slurm-array.sh"), str(config)],
                              env=slamq_env({**slamq_env(), "SLURM_ARRAY_TASK_ID": str(i),
                                             "SLURM_ARRAY_TASK_MIN": "1",
                                             "SLURM_ARRAY_TASK_COUNT": "3"}),
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for i in (1, 2, 3)]  # sbatch --array=1-3
    for p in procs:
        out, err = p.communicate(timeout=60)
        assert p.returncode == 0, err
    rows = _merged(tmp_path, config)
    assert len(rows) == 9 and {r["outcome"] for r in rows} == {"ok"}
    assert sorted((tmp_path / "ran.txt").read_text().split()) == ["1", "2", "3"]
    p = subprocess.run(["bash", str(RECIPES / "slurm-array.sh"), str(config)],
                       capture_output=True, text=True, env=slamq_env())
    assert p.returncode != 0 and "not in a Slurm array job" in p.stderr


def test_the_kubernetes_indexed_job_runs_its_shards_then_the_merge(tmp_path: Path) -> None:
    docs = list(yaml.safe_load_all((RECIPES / "k8s-indexed-job.yaml").read_text()))
    pvc, shards, merge = docs
    assert pvc["kind"] == "PersistentVolumeClaim" and "ReadWriteMany" in pvc["spec"]["accessModes"]
    spec = shards["spec"]
    assert spec["completionMode"] == "Indexed"
    (container,) = spec["template"]["spec"]["containers"]
    cmd = container["command"]
    assert cmd[:2] == ["slamq", "run"] and cmd[cmd.index("--shard") + 1] == str(spec["completions"])
    (merger,) = merge["spec"]["template"]["spec"]["containers"]
    assert merger["command"][-1] == "--merge" and merger["command"][2] == cmd[2]
    for job in (shards, merge):  # both see the same volume
        vols = job["spec"]["template"]["spec"]["volumes"]
        assert {"name": "runs", "persistentVolumeClaim": {"claimName": pvc["metadata"]["name"]}} \
            in vols
    config = _config(tmp_path)
    local = [str(config) if c == cmd[2] else c for c in cmd]
    procs = [subprocess.Popen(local, env=slamq_env({**slamq_env(), "JOB_COMPLETION_INDEX": str(i)}),
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
             for i in range(spec["completions"])]
    for p in procs:
        _, err = p.communicate(timeout=60)
        assert p.returncode == 0, err
    rows = _merged(tmp_path, config)
    assert len(rows) == 9 and {r["outcome"] for r in rows} == {"ok"}


def _recipe(name: str):
    spec = importlib.util.spec_from_file_location(name, RECIPES / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_the_dask_jobqueue_recipe_declares_the_slots() -> None:
    pytest.importorskip("dask_jobqueue")
    cluster = _recipe("slamq_dask_slurm").make_cluster(jobs=0, slots=2, walltime="01:00:00")
    try:
        script = cluster.job_script()
    finally:
        cluster.close()
    assert "--resources slamq_run=2" in script and "--cpus-per-task=4" in script


def test_the_dask_kubernetes_recipe_declares_the_slots() -> None:
    pytest.importorskip("dask_kubernetes.operator")
    spec = _recipe("slamq_dask_kubernetes").cluster_spec("slamq", "img", workers=3, slots=2)
    worker = spec["spec"]["worker"]
    assert worker["replicas"] == 3
    args = worker["spec"]["containers"][0]["args"]
    assert args[-4:] == ["--nthreads", "2", "--resources", "slamq_run=2"]


def test_the_array_script_says_when_slamq_is_not_on_path(tmp_path: Path) -> None:
    """Issue 43, point 7: without slamq on PATH inside the job every task ended with
    'exec: slamq: not found'; the script now says what to do."""
    env = {"PATH": "/usr/bin:/bin", "SLURM_ARRAY_TASK_ID": "0", "SLURM_ARRAY_TASK_COUNT": "1"}
    p = subprocess.run(["bash", str(RECIPES / "slurm-array.sh"), str(tmp_path / "run.yaml")],
                       capture_output=True, text=True, env=env, timeout=60)
    assert p.returncode == 127 and "slamq is not on PATH inside the job" in p.stderr


def test_the_examples_seed_every_rbpf_slam_run() -> None:
    """Issue 43, point 7: a run equal to a local one needs a seeded particle filter (the
    held-out sets in studies/ are kept as they were run)."""
    examples = RECIPES.parents[1] / "examples"
    for path in sorted(examples.glob("*.yaml")):
        cfg = yaml.safe_load(path.read_text())
        rbpf = (cfg.get("algorithms") or {}).get("rbpf-slam")
        if rbpf is not None:
            assert "MappingApplication.RANDOM_SEED" in rbpf["config_overrides"], path
