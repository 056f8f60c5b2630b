"""The Slurm recipes on a real single-node Slurm (slurmctld + slurmd + munged on loopback,
started by ``.ci/slurm up DIR``, found by ``SLURM_CONF``): the array script and its merge
job equal a local run, a requeued task resumes its shard, a cancelled task makes the merge
fail until its shard is submitted again by the documented command, and the dask-jobqueue
recipe runs the same plan in Slurm jobs (issue 43).

Without a running Slurm these tests skip, saying how to start one; CI starts one and sets
``SLAMQ_REQUIRE_SLURM=1``, which turns the skip into a failure.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import REPO, slamq_env
from test_shards import _config, _runs, _table, _yaml

RECIPES = REPO / "examples" / "distributed"
ARRAY = RECIPES / "slurm-array.sh"
#: Seconds a test waits for its jobs at most (the node has 2 cores, shared with the suite).
WAIT = 600


@pytest.fixture(scope="module")
def slurm() -> dict[str, str]:
    """The environment for sbatch and for the jobs: this slamq and this Python first on
    PATH (sbatch exports the submitting environment to the job)."""
    conf = os.environ.get("SLURM_CONF", "")
    why = ""
    if not conf or shutil.which("sbatch") is None:
        why = "no SLURM_CONF or no sbatch"
    else:
        p = subprocess.run(["sinfo", "-h", "-o", "%T"], capture_output=True, text=True,
                           timeout=30)
        if p.returncode != 0 or not p.stdout.strip():
            why = f"sinfo failed: {p.stderr.strip()}"
    if why:
        msg = (f"no Slurm ({why}): start one with eval \"$(.ci/slurm up /tmp/slamq-slurm)\" "
               "(root; installs slurm-wlm and munge)")
        if os.environ.get("SLAMQ_REQUIRE_SLURM"):
            pytest.fail(msg)
        pytest.skip(msg)
    env = slamq_env()
    env["PATH"] = os.pathsep.join([str(Path(sys.executable).parent), env.get("PATH", "")])
    return env


def _sbatch(env: dict[str, str], cwd: Path, *args: str) -> str:
    p = subprocess.run(["sbatch", "--parsable", f"--chdir={cwd}", *args], capture_output=True,
                       text=True, env=env, timeout=60)
    assert p.returncode == 0, p.stderr
    return p.stdout.strip().split(";")[0]


def _jobs(env: dict[str, str], job: str) -> dict[str, tuple[str, str]]:
    """``{job or array task id: (state, exit code)}`` from ``scontrol show job``."""
    p = subprocess.run(["scontrol", "-o", "show", "job", job], capture_output=True, text=True,
                       env=env, timeout=60)
    out = {}
    for line in p.stdout.splitlines():
        fields = dict(re.findall(r"(\w+)=(\S*)", line))
        task = fields.get("ArrayTaskId")
        name = f"{fields.get('ArrayJobId')}_{task}" if task and task.isdigit() else \
            fields.get("JobId", "")
        out[name] = (fields.get("JobState", ""), fields.get("ExitCode", ""))
    return out


def _wait(env: dict[str, str], job: str, until: set[str] | None = None) -> dict:
    """Wait until every task of ``job`` is in a final state (or one of ``until``)."""
    final = until or {"COMPLETED", "FAILED", "CANCELLED", "TIMEOUT", "NODE_FAIL",
                      "OUT_OF_MEMORY", "PREEMPTED"}
    deadline = time.monotonic() + WAIT
    while time.monotonic() < deadline:
        states = _jobs(env, job)
        if states and all(s in final for s, _ in states.values()):
            return states
        time.sleep(0.5)
    raise AssertionError(f"job {job} not done in {WAIT} s: {_jobs(env, job)}")


def _until(predicate, what: str) -> None:
    deadline = time.monotonic() + WAIT
    while not predicate():
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(0.2)


def test_the_array_and_its_merge_job_equal_a_local_run(slurm: dict[str, str],
                                                       tmp_path: Path) -> None:
    path = _yaml(tmp_path, _config(tmp_path))
    t0 = time.monotonic()
    local = subprocess.run(["slamq", "run", str(path)], capture_output=True, text=True,
                           env=slurm, timeout=WAIT)
    local_s = time.monotonic() - t0
    assert local.returncode == 0, local.stderr
    want_runs, want_table = _runs(tmp_path / "out"), _table(tmp_path / "out")
    shutil.move(tmp_path / "out", tmp_path / "local")
    t0 = time.monotonic()
    jid = _sbatch(slurm, tmp_path, "--array=0-2", f"--output={tmp_path}/task-%A_%a.log",
                  str(ARRAY), str(path))
    mid = _sbatch(slurm, tmp_path, f"--dependency=afterany:{jid}", "--cpus-per-task=2",
                  f"--output={tmp_path}/merge.log", "--wrap", f"slamq run {path} --merge")
    tasks = _wait(slurm, jid)
    merged = _wait(slurm, mid)
    slurm_s = time.monotonic() - t0
    assert set(tasks.values()) == {("COMPLETED", "0:0")}, tasks
    assert merged == {mid: ("COMPLETED", "0:0")}, (tmp_path / "merge.log").read_text()
    assert _runs(tmp_path / "out") == want_runs
    assert _table(tmp_path / "out") == want_table
    log = (tmp_path / "merge.log").read_text()
    assert "merged: 9 finished runs (9 ok)" in log
    print(f"\n9 runs: local {local_s:.1f} s, Slurm array of 3 + merge job {slurm_s:.1f} s "
          f"(submit to finish; {(slurm_s - local_s) / 9:+.2f} s per run)")


def _blocking_config(tmp: Path) -> Path:
    """Three runs in one shard; the second waits for ``tmp/go``; every start is counted."""
    cfg = _config(tmp)
    counter, go = tmp / "started.txt", tmp / "go"
    cfg["iterations"] = 3
    cfg["algorithms"] = {"gate": {
        "command": ["sh", "-c", f"echo {{iteration}} >> {counter}; if [ {{iteration}} = 2 ]; "
                    f"then while [ ! -f {go} ]; do sleep 0.1; done; fi"]}}
    return _yaml(tmp, cfg)


def _started(tmp: Path) -> list[str]:
    p = tmp / "started.txt"
    return p.read_text().split() if p.exists() else []


def test_a_requeued_task_resumes_its_shard(slurm: dict[str, str], tmp_path: Path) -> None:
    path = _blocking_config(tmp_path)
    jid = _sbatch(slurm, tmp_path, "--array=0", f"--output={tmp_path}/task-%A_%a.log",
                  str(ARRAY), str(path), "1")
    _until(lambda: "2" in _started(tmp_path), "run 2 to start")
    p = subprocess.run(["scontrol", "requeue", f"{jid}_0"], capture_output=True, text=True,
                       env=slurm, timeout=60)
    assert p.returncode == 0, p.stderr
    # the requeued task starts again: run 1 is found done, run 2 starts a second time
    _until(lambda: _started(tmp_path).count("2") == 2, "the requeued task to start run 2")
    (tmp_path / "go").write_text("")
    states = _wait(slurm, jid)
    assert set(states.values()) == {("COMPLETED", "0:0")}, states
    assert sorted(_started(tmp_path)) == ["1", "2", "2", "3"]  # run 1 never ran again
    assert {r[3] for r in _runs_after_merge(slurm, tmp_path, path)} == {"ok"}


def _runs_after_merge(env: dict[str, str], tmp: Path, path: Path) -> list[tuple]:
    p = subprocess.run(["slamq", "run", str(path), "--merge"], capture_output=True, text=True,
                       env=env, timeout=WAIT)
    assert p.returncode == 0, p.stderr
    return _runs(tmp / "out")


def test_a_cancelled_task_fails_the_merge_until_its_shard_runs_again(
        slurm: dict[str, str], tmp_path: Path) -> None:
    path = _blocking_config(tmp_path)
    jid = _sbatch(slurm, tmp_path, "--array=0-2", f"--output={tmp_path}/task-%A_%a.log",
                  str(ARRAY), str(path))
    # shard 1 of 3 holds iteration 2 (round-robin), which waits: cancel that task
    _until(lambda: "2" in _started(tmp_path), "run 2 to start")
    subprocess.run(["scancel", f"{jid}_1"], env=slurm, timeout=60, check=True)
    mid = _sbatch(slurm, tmp_path, f"--dependency=afterany:{jid}",
                  f"--output={tmp_path}/merge.log", "--wrap", f"slamq run {path} --merge")
    tasks = _wait(slurm, jid)
    assert tasks[f"{jid}_1"][0] == "CANCELLED" and tasks[f"{jid}_0"] == ("COMPLETED", "0:0")
    assert _wait(slurm, mid)[mid] == ("FAILED", "3:0")
    log = (tmp_path / "merge.log").read_text()
    assert "shard 1/3 (interrupted): 1" in log, log
    # the documented command runs shard 1 of the original 3 (N from the output folder)
    (tmp_path / "go").write_text("")
    again = _sbatch(slurm, tmp_path, "--array=1", f"--output={tmp_path}/again-%A_%a.log",
                    str(ARRAY), str(path))
    assert set(_wait(slurm, again).values()) == {("COMPLETED", "0:0")}
    assert "shard 1/3:" in (tmp_path / f"again-{again}_1.log").read_text()
    rows = _runs_after_merge(slurm, tmp_path, path)
    assert len(rows) == 3 and {r[3] for r in rows} == {"ok"}


def test_the_dask_jobqueue_recipe_runs_the_plan_in_slurm_jobs(slurm: dict[str, str],
                                                               tmp_path: Path) -> None:
    pytest.importorskip("dask_jobqueue")
    path = _yaml(tmp_path, _config(tmp_path))
    local = subprocess.run(["slamq", "run", str(path)], capture_output=True, text=True,
                           env=slurm, timeout=WAIT)
    assert local.returncode == 0, local.stderr
    want = _table(tmp_path / "out")
    shutil.move(tmp_path / "out", tmp_path / "local")
    script = str(RECIPES / "slamq_dask_slurm.py")
    too_big = subprocess.run([sys.executable, script, str(path), "--jobs", "1", "--slots",
                              "64"], capture_output=True, text=True, env=slurm, timeout=120,
                             cwd=tmp_path)
    assert too_big.returncode != 0 and "no node of the default partition" in too_big.stderr
    p = subprocess.run([sys.executable, script, str(path), "--jobs", "1", "--slots", "1",
                        "--cores-per-run", "1", "--memory", "2GB", "--walltime", "00:20:00",
                        "--interface", "lo", "--start-timeout", "300"],
                       capture_output=True, text=True, env=slurm, timeout=WAIT, cwd=tmp_path)
    assert p.returncode == 0, p.stderr
    (line,) = p.stdout.strip().splitlines()
    assert line.startswith("slamq: 9 runs (9 ok; ran 9) in ") and "on 1 Slurm job(s)" in line
    assert _table(tmp_path / "out") == want
