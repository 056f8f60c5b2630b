"""``slamq run --shard I/N`` as separate processes, ``--merge`` (idempotent), the array-job
environment variables, and the guard against a plain run while a shard runs."""

from __future__ import annotations

import json
import os
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
from conftest import slamq_env

from slamq.errors import ParamError, SlamqError
from slamq.results import read_results
from slamq.runner import load_config, runner, shards

PY = sys.executable

SLAM = """\
import pathlib, sys
out, n, it = pathlib.Path(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
w = h = 30
img = bytearray([254]) * (w * h)
for y in range(4, 4 + n + it):
    img[y * w + 3:y * w + 27] = bytes([0]) * 24
(out / "map.pgm").write_bytes(b"P5\\n%d %d\\n255\\n" % (w, h) + bytes(img))
(out / "traj.txt").write_text("".join(f"{i} {i + 0.05 * n * it} 0 0 0 0 0 1\\n"
                                      for i in range(6)))
"""


def _config(tmp: Path) -> dict:
    (tmp / "slam.py").write_text(SLAM)
    (tmp / "in.txt").write_text("input\n")
    (tmp / "gt.txt").write_text("".join(f"{i} {i} 0 0 0 0 0 1\n" for i in range(6)))
    return {"output": "out", "iterations": 3, "report": False, "parallel": 1,
            "sequences": {"seq": {"input": "in.txt", "groundtruth": "gt.txt"}},
            "algorithms": {
                "fake": {"command": [PY, str(tmp / "slam.py"), "{out}", "{param.n}",
                                     "{iteration}"],
                         "params": {"n": [1, 3]},
                         "outputs": {"map": {"path": "map.pgm", "format": "image"},
                                     "trajectory": {"path": "traj.txt", "format": "tum"}}},
                "other": {"command": [PY, str(tmp / "slam.py"), "{out}", "2", "{iteration}"],
                          "outputs": {"map": {"path": "map.pgm", "format": "image"}}}}}


def _yaml(tmp: Path, cfg: dict) -> Path:
    import yaml

    p = tmp / "run.yaml"
    p.write_text(yaml.safe_dump(cfg))
    return p


def _cli(*args: str, env: dict | None = None) -> subprocess.Popen:
    return subprocess.Popen([PY, "-m", "slamq", "run", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=slamq_env(env))


def _table(out: Path) -> list[tuple]:
    df = read_results(out / "results.jsonl").sort_values(["algorithm", "run"])
    cols = ["algorithm", "sequence", "run", "occupied", "known", "ate_rmse"]
    return [tuple(None if v != v else v for v in r) for r in df[cols].itertuples(index=False)]


def _runs(out: Path) -> list[tuple]:
    import csv

    with open(out / "runs.csv") as f:
        return sorted((r["algorithm"], r["iteration"], r["key"], r["outcome"])
                      for r in csv.DictReader(f))


def test_four_shards_as_processes_merged_equal_one_unsharded_run(tmp_path: Path) -> None:
    cfg = _config(tmp_path)
    path = _yaml(tmp_path, cfg)
    whole = _cli(str(path))
    out, err = whole.communicate(timeout=60)
    assert whole.returncode == 0, err
    want_runs, want_table = _runs(tmp_path / "out"), _table(tmp_path / "out")
    assert len(want_runs) == 9
    shutil.move(tmp_path / "out", tmp_path / "unsharded")
    procs = [_cli(str(path), "--shard", f"{i}/4") for i in range(4)]
    for i, p in enumerate(procs):
        out, err = p.communicate(timeout=60)
        assert p.returncode == 0, err
        assert f"shard {i}/4:" in out
    records = [json.loads((tmp_path / "out" / "shards" / f"{i}-of-4.json").read_text())
               for i in range(4)]
    keys = [r["key"] for rec in records for r in rec["runs"]]
    assert sorted(len(rec["runs"]) for rec in records) == [2, 2, 2, 3]
    assert len(keys) == len(set(keys)) == 9  # a partition of the plan
    assert not (tmp_path / "out" / "results.jsonl").exists()  # shards score nothing
    merged = _cli(str(path), "--merge")
    out, err = merged.communicate(timeout=60)
    assert merged.returncode == 0, err
    assert "merged: 9 finished runs (9 ok)" in out
    assert _runs(tmp_path / "out") == want_runs
    assert _table(tmp_path / "out") == want_table
    import pandas as pd

    a, b = (pd.read_csv(tmp_path / d / "summary.csv") for d in ("out", "unsharded"))
    timing = [c for c in a if c.startswith(("wall_s", "cpu_s", "peak_rss_mb"))]
    assert timing  # the resources are summarised too, but differ between two executions
    pd.testing.assert_frame_equal(a.drop(columns=timing), b.drop(columns=timing))
    # merging again changes nothing; a plain run merges too and runs nothing again
    first = (tmp_path / "out" / "results.jsonl").read_text()
    result = shards.merge(path)
    assert (tmp_path / "out" / "results.jsonl").read_text() == first
    assert len(result["rows"]) == 9 and result["missing"] == []
    rows = runner.execute(path)
    assert all(r.get("skipped") for r in rows)


def test_merge_names_the_missing_shard_and_a_plain_run_finishes_it(tmp_path: Path) -> None:
    path = _yaml(tmp_path, _config(tmp_path))
    for i in (0, 2):
        shards.run_shard(path, (i, 3))
    result = shards.merge(path)
    assert len(result["rows"]) == 6
    assert {s for s, _ in result["missing"]} == {"1/3"} and len(result["missing"]) == 3
    assert len(read_results(tmp_path / "out" / "results.jsonl")) == 6
    full = runner.run(path)  # the next plain run: runs shard 1's runs, scores all nine
    assert sum(not r.get("skipped") for r in full["rows"]) == 3
    assert len(read_results(tmp_path / "out" / "results.jsonl")) == 9


def test_the_shard_index_from_array_job_environments(tmp_path: Path) -> None:
    path = _yaml(tmp_path, _config(tmp_path))
    p = _cli(str(path), "--shard", "3", env={"SLURM_ARRAY_TASK_ID": "3",
                                               "SLURM_ARRAY_TASK_MIN": "1",
                                               "SLURM_ARRAY_TASK_MAX": "3",
                                               "SLURM_ARRAY_TASK_COUNT": "3"})
    out, err = p.communicate(timeout=60)
    assert p.returncode == 0 and "shard 2/3:" in out, err
    p = _cli(str(path), "--shard", "3", env={"JOB_COMPLETION_INDEX": "0"})
    out, err = p.communicate(timeout=60)
    assert p.returncode == 0 and "shard 0/3:" in out, err
    with pytest.raises(ParamError, match="no shard index"):
        shards.parse_shard("3", {})


def test_a_plain_run_refuses_while_a_shard_runs(tmp_path: Path) -> None:
    path = _yaml(tmp_path, _config(tmp_path))
    cfg = load_config(path)
    marker = cfg.output / "shards" / "1-of-2.running"
    marker.parent.mkdir(parents=True)
    marker.write_text("otherhost 123\n")
    with pytest.raises(SlamqError, match="shard 1/2 is running"):
        shards.check_no_live_shard(cfg)
    p = _cli(str(path))
    _, err = p.communicate(timeout=60)
    assert p.returncode == 2 and "1-of-2.running" in err


def _slurm(task: int, low: int, high: int, count: int, step: int = 1) -> dict[str, str]:
    return {"SLURM_ARRAY_TASK_ID": str(task), "SLURM_ARRAY_TASK_MIN": str(low),
            "SLURM_ARRAY_TASK_MAX": str(high), "SLURM_ARRAY_TASK_COUNT": str(count),
            "SLURM_ARRAY_TASK_STEP": str(step)}


def test_shard_indices_from_stepped_listed_and_one_task_arrays(tmp_path: Path) -> None:
    """Issue 43, point 3: --array=0-4:2 is shards 0..2 of 3; --array=2 (a shard submitted
    again) is shard 2 of the N given or recorded, never 0/1 (the whole plan); listed
    arrays take their ids as shard indices; without N the error gives the command."""
    assert [shards.parse_shard("auto", _slurm(t, 0, 4, 3, 2)) for t in (0, 2, 4)] == [
        (0, 3), (1, 3), (2, 3)]
    assert shards.parse_shard("4", _slurm(2, 2, 2, 1)) == (2, 4)
    assert shards.parse_shard("auto", _slurm(2, 2, 2, 1), known=4) == (2, 4)
    assert [shards.parse_shard("4", _slurm(t, 1, 3, 2)) for t in (1, 3)] == [(1, 4), (3, 4)]
    with pytest.raises(ParamError, match=r"sbatch --array=2 slurm-array.sh CONFIG N"):
        shards.parse_shard("auto", _slurm(2, 2, 2, 1))
    with pytest.raises(ParamError, match="must be in 0..3"):
        shards.parse_shard("4", _slurm(5, 5, 5, 1))
    path = _yaml(tmp_path, _config(tmp_path))
    shards.run_shard(path, (0, 4))  # the first submission recorded N = 4
    p = _cli(str(path), "--shard", "auto", env={**os.environ, **_slurm(2, 2, 2, 1)})
    out, err = p.communicate(timeout=60)
    assert p.returncode == 0 and "shard 2/4:" in out, err


def test_a_second_copy_of_a_running_shard_refuses_and_keeps_the_first(tmp_path: Path
                                                                       ) -> None:
    """Issue 43, point 1: a requeued or resubmitted copy of a running shard exits 2 naming
    the running process, runs nothing, and leaves the first copy's marker alone; a marker
    whose process is gone (killed) is taken over."""
    cfg = _config(tmp_path)
    go = tmp_path / "go"  # the first copy's run waits for it
    cfg["algorithms"] = {"slow": {"command": ["sh", "-c", f"while [ ! -f {go} ]; do sleep 0.05; "
                                              "done"]}}
    cfg["iterations"] = 1
    path = _yaml(tmp_path, cfg)
    first = _cli(str(path), "--shard", "0/1")
    marker = tmp_path / "out" / "shards" / "0-of-1.running"
    for _ in range(200):
        if marker.exists() and marker.read_text().strip():
            break
        time.sleep(0.05)
    owner = marker.read_text()
    second = _cli(str(path), "--shard", "0/1")
    out, err = second.communicate(timeout=60)
    assert second.returncode == 2 and "already running" in err
    assert owner.split()[1] in err  # names the first copy's pid
    assert marker.read_text() == owner  # the first copy's marker is still there
    go.write_text("")
    out, err = first.communicate(timeout=60)
    assert first.returncode == 0 and "ran 1 (1 ok)" in out, err
    assert not marker.exists()
    # a dead process's marker: taken over at once
    marker.write_text(f"{socket.gethostname()} 999999999\n")
    again = _cli(str(path), "--shard", "0/1")
    out, err = again.communicate(timeout=60)
    assert again.returncode == 0 and "ran 0" in out and "found 1 done (1 ok)" in out, err


def test_merge_of_unfinished_runs_and_a_failed_shard_exit_3(tmp_path: Path) -> None:
    """Issue 43, point 2: --merge with runs not finished exits 3 naming each shard's state
    (--partial exits 0); a shard with a run that is not ok exits 3."""
    cfg = _config(tmp_path)
    cfg["algorithms"]["crasher"] = {"command": ["sh", "-c", "exit 3"],
                                   "outputs": {"map": {"path": "map.pgm", "format": "image"}}}
    path = _yaml(tmp_path, cfg)
    n = 4
    codes = {}
    for i in (0, 1):
        p = _cli(str(path), "--shard", f"{i}/{n}")
        out, err = p.communicate(timeout=120)
        codes[i] = (p.returncode, out, err)
    assert {code for code, _, _ in codes.values()} <= {0, 3}
    crashed = [i for i, (code, _, _) in codes.items() if code == 3]
    assert crashed and all("not ok" in codes[i][2] for i in crashed)
    p = _cli(str(path), "--merge")
    out, err = p.communicate(timeout=120)
    assert p.returncode == 3, err
    assert "shard 2/4 (missing)" in err and "shard 3/4 (missing)" in err
    assert "merged:" in out and (tmp_path / "out" / "results.jsonl").exists()
    p = _cli(str(path), "--merge", "--partial")
    out, err = p.communicate(timeout=120)
    assert p.returncode == 0 and "not finished" in err, err


def test_a_moved_output_folder_keeps_its_run_keys(tmp_path: Path) -> None:
    """Issue 43, point 4: run keys hold paths relative to the output folder and the
    config's folder, so a finished experiment copied elsewhere (or mounted at another path
    on the login node) merges all its runs and reruns none."""
    first = tmp_path / "cluster"
    first.mkdir()
    path = _yaml(first, _config(first))
    for i in range(2):
        shards.run_shard(path, (i, 2))
    moved = tmp_path / "login" / "mnt"
    shutil.copytree(first, moved)
    shutil.rmtree(first)  # the scripts the runs called are gone too: nothing may run
    result = shards.merge(moved / "run.yaml")
    assert len(result["rows"]) == 9 and result["missing"] == []
    rows = runner.execute(moved / "run.yaml")
    assert len(rows) == 9 and all(r.get("skipped") for r in rows)


def test_generated_sequences_are_made_under_a_lock(tmp_path: Path) -> None:
    """Issue 43, point 5: two shards starting together would both write a generated
    sequence's folder; the second waits on <output>/sequences/.lock and finds it made."""
    import fcntl
    import threading

    from slamq.runner.planning import prepare_inputs

    cfg = load_config({
        "base_dir": str(tmp_path), "output": "out", "report": False,
        "sequences": {"gen": {"synth": {"worlds": 1, "noise": ["none"], "seeds": [0],
                                        "input": "carmen"}}},
        "algorithms": {"a": {"command": ["true"]}}})
    lock = tmp_path / "out" / "sequences" / ".lock"
    lock.parent.mkdir(parents=True)
    done = threading.Event()
    with open(lock, "a") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX)  # another shard generating
        t = threading.Thread(target=lambda: (prepare_inputs(cfg), done.set()))
        t.start()
        time.sleep(1.0)
        assert not done.is_set()  # it waits for the lock
        fcntl.flock(fh, fcntl.LOCK_UN)
    t.join(timeout=300)
    assert done.is_set()
    (gen,) = [s.generated for s in cfg.sequences]
    assert gen.complete()
    stamp = (gen.folder / "recipe.json").stat().st_mtime_ns
    prepare_inputs(cfg)  # made: not again
    assert (gen.folder / "recipe.json").stat().st_mtime_ns == stamp
