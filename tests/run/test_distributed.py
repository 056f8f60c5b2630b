"""``slamq run --scheduler``: runs as tasks on a real Dask cluster (``dask scheduler`` and
``dask worker`` processes on 127.0.0.1), shared and returned outputs, slots, and the faults:
a worker killed mid-run, the scheduler gone, Ctrl-C of the client."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from _daskproc import Cluster, available, can_hide, stop
from conftest import slamq_env

from slamq.results import read_results
from slamq.runner import runner
from slamq.runner.distributed import dask_backend

pytestmark = pytest.mark.skipif(not available(), reason="dask.distributed not installed")

PY = sys.executable

#: A "SLAM program": sleeps, writes a map_server map and a TUM trajectory that depend on
#: the parameter n, appends "pid" to started.log first and "folder" to done.log last.
SLAM = """\
import os, pathlib, sys, time
out, n, sleep, logs = pathlib.Path(sys.argv[1]), int(sys.argv[2]), float(sys.argv[3]), sys.argv[4]
with open(os.path.join(logs, "started.log"), "a") as f:
    f.write(f"{os.getpid()} {os.environ.get('VICTIM', '0')}\\n")
time.sleep(sleep)
w = h = 40
img = bytearray([254]) * (w * h)
for y in range(5, 5 + n):
    img[y * w + 5:y * w + 35] = bytes([0]) * 30
(out / "map.pgm").write_bytes(b"P5\\n%d %d\\n255\\n" % (w, h) + bytes(img))
(out / "map.yaml").write_text("image: map.pgm\\nresolution: 0.05\\norigin: [0, 0, 0]\\n"
                              "negate: 0\\noccupied_thresh: 0.65\\nfree_thresh: 0.196\\n")
(out / "traj.txt").write_text("".join(f"{i} {i + 0.1 * n} 0 0 0 0 0 1\\n" for i in range(5)))
with open(os.path.join(logs, "done.log"), "a") as f:
    f.write(str(out) + "\\n")
"""


def _config(tmp: Path, sleep: float = 0.2, iterations: int = 2, **extra) -> dict:
    (tmp / "slam.py").write_text(SLAM)
    (tmp / "in.txt").write_text("input\n")
    (tmp / "gt.txt").write_text("".join(f"{i} {i} 0 0 0 0 0 1\n" for i in range(5)))
    return {"base_dir": str(tmp), "output": "out", "iterations": iterations, "report": False,
            "grace": [0.5, 0.5], "parallel": 2,
            "sequences": {"seq": {"input": "in.txt", "groundtruth": "gt.txt"}},
            "algorithms": {"fake": {
                "command": [PY, str(tmp / "slam.py"), "{out}", "{param.n}", str(sleep), str(tmp)],
                "params": {"n": [2, 4]},
                "outputs": {"map": {"path": "map.yaml", "format": "yaml"},
                            "trajectory": {"path": "traj.txt", "format": "tum"}}}}, **extra}


def _yaml(tmp: Path, cfg: dict) -> Path:
    import yaml

    cfg = {k: v for k, v in cfg.items() if k != "base_dir"}
    p = tmp / "run.yaml"
    p.write_text(yaml.safe_dump(cfg))
    return p


def _alive(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().split()[2] != "Z"
    except OSError:
        return False


def _numbers(out: Path) -> list[tuple]:
    df = read_results(out / "results.jsonl").sort_values(["algorithm", "run"])
    cols = ["algorithm", "sequence", "run", "occupied", "known", "corners", "ate_rmse"]
    return [tuple(None if v != v else v for v in r) for r in df[cols].itertuples(index=False)]


def _dump(proc: subprocess.Popen, tmp: Path) -> str:
    if proc.poll() is None:
        proc.kill()
    out, err = proc.communicate()
    return f"{out}\n{err}\n" + "\n".join(str(p) for p in tmp.rglob("*"))


def _keys(rows: list[dict]) -> list[tuple]:
    return sorted((r["algorithm"], r["iteration"], r["key"], r["outcome"]) for r in rows)


@pytest.fixture(scope="module")
def cluster(tmp_path_factory: pytest.TempPathFactory):
    c = Cluster(tmp_path_factory.mktemp("dask"))
    try:
        c.add_worker("w1")
        c.add_worker("w2", resources="slamq_run=2", nthreads=2)
        yield c
    finally:
        c.close()


def test_dask_runs_equal_the_local_run_in_shared_and_returned_modes(
        tmp_path: Path, cluster: Cluster) -> None:
    cfg = _config(tmp_path)
    local = runner.run(cfg)
    assert [r["outcome"] for r in local["rows"]] == ["ok"] * 4
    want_keys, want_numbers = _keys(local["rows"]), _numbers(tmp_path / "out")
    for outputs in ("shared", "return", "auto"):
        shutil.rmtree(tmp_path / "out")
        got = runner.run(cfg, backend=dask_backend(cluster.address, outputs))
        assert _keys(got["rows"]) == want_keys, outputs
        assert _numbers(tmp_path / "out") == want_numbers, outputs
        for r in got["rows"]:  # the run folder as a local run leaves it, run.json last
            folder = Path(r["folder"])
            assert (folder / "out" / "map.pgm").exists() and (folder / "trajectory.tum").exists()
            stored = json.loads((folder / "run.json").read_text())
            assert stored["key"] == r["key"] and stored["map"].startswith(str(folder))
            assert stored["wall"] > 0 and stored["max_rss_kb"] > 0
    # finished runs are skipped by the next call, here or on Dask
    again = runner.execute(cfg, backend=dask_backend(cluster.address))
    assert all(r.get("skipped") for r in again)
    assert len((tmp_path / "done.log").read_text().split()) == 4 * 4


def test_slots_per_worker(tmp_path: Path, cluster: Cluster) -> None:
    # w1 declares nothing (one slot), w2 declares slamq_run=2: never more than 3 at once
    cfg = _config(tmp_path, sleep=0.6, iterations=3)
    cfg["algorithms"]["fake"]["command"] = (
        f"echo start $(date +%s.%N) >> {tmp_path}/t.log; sleep 0.6; "
        f"echo end $(date +%s.%N) >> {tmp_path}/t.log")
    cfg["algorithms"]["fake"].pop("outputs")
    rows = runner.execute(cfg, backend=dask_backend(cluster.address))
    assert [r["outcome"] for r in rows] == ["ok"] * 6
    events = sorted((float(t), 1 if k == "start" else -1)
                    for k, t in (line.split() for line in (tmp_path / "t.log").read_text()
                                 .splitlines()))
    level = peak = 0
    for _, d in events:
        level += d
        peak = max(peak, level)
    assert peak == 3


@pytest.mark.parametrize("signals", [("INT",), ("INT", "INT", "TERM", "INT")])
def test_ctrl_c_of_the_client_stops_the_workers_groups(tmp_path: Path, cluster: Cluster,
                                                       signals: tuple[str, ...]) -> None:
    # also a burst: a second Ctrl-C (or a scheduler's SIGTERM after it) used to be able to
    # land before the first one's stopping had begun and abandon it
    cfg = _config(tmp_path)
    cfg["algorithms"] = {name: {"command": "sleep 60 & echo $! > {out}/child.pid; wait"}
                         for name in ("a", "b")}
    proc = subprocess.Popen([PY, "-m", "slamq", "run", str(_yaml(tmp_path, cfg)),
                             "--scheduler", cluster.address], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=slamq_env())
    try:
        # each attempt runs in .<iteration>.attempt-ID beside its run folder
        end = time.monotonic() + 60
        while True:
            pids = list((tmp_path / "out").glob("*/default/seq/.*attempt*/out/child.pid"))
            started = [int(t) for t in (p.read_text().strip() for p in pids) if t]
            if len(started) >= 3:
                break
            assert time.monotonic() < end and proc.poll() is None, _dump(proc, tmp_path)
            time.sleep(0.05)
        for name in signals:
            proc.send_signal(getattr(signal, f"SIG{name}"))
        _, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, err
    assert not any(_alive(pid) for pid in started)
    assert not list((tmp_path / "out").glob("*/default/seq/*/run.json"))
    assert not list((tmp_path / "out").glob("*/default/seq/.*attempt*"))  # nothing left


def test_a_worker_killed_mid_run_loses_no_run_and_duplicates_none(
        tmp_path: Path, cluster: Cluster) -> None:
    victim = cluster.add_worker("victim", env={"VICTIM": "1"}, resources="slamq_run=1")
    proc = None
    try:
        cfg = _config(tmp_path, sleep=1.5, iterations=3)
        proc = subprocess.Popen([PY, "-m", "slamq", "run", str(_yaml(tmp_path, cfg)),
                                 "--scheduler", cluster.address], stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True, env=slamq_env())
        log = tmp_path / "started.log"
        end = time.monotonic() + 60
        while not (log.exists() and " 1\n" in log.read_text()):
            assert time.monotonic() < end and proc.poll() is None, "the victim never ran"
            time.sleep(0.05)
        killed = [int(line.split()[0]) for line in log.read_text().splitlines()
                  if line.endswith(" 1")]
        os.killpg(victim.pid, signal.SIGKILL)  # the worker and its nanny, at once
        out, err = proc.communicate(timeout=90)
    finally:
        stop(victim, grace=0)
        if proc is not None and proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, err
    assert "runs: 6 ok" in out
    done = (tmp_path / "done.log").read_text().split()
    assert len(done) == len(set(done)) == 6  # every run finished once
    assert len(log.read_text().splitlines()) > 6  # the killed run started again elsewhere
    assert len(list((tmp_path / "out").glob("fake/*/seq/*/run.json"))) == 6
    assert not list((tmp_path / "out").glob("fake/*/seq/.*attempt*"))  # the dead one's too
    assert len(read_results(tmp_path / "out" / "results.jsonl")) == 6
    end = time.monotonic() + 10  # the dead worker's guard stopped its SLAM process
    while any(_alive(p) for p in killed) and time.monotonic() < end:
        time.sleep(0.05)
    assert not any(_alive(p) for p in killed)


def test_the_scheduler_gone_exits_2_naming_what_finished(tmp_path: Path) -> None:
    own = Cluster(tmp_path / "dask")
    proc = None
    try:
        own.add_worker("only", resources="slamq_run=2", nthreads=2)
        cfg = _config(tmp_path, sleep=0.3, iterations=4)
        cfg["algorithms"]["fake"]["params"] = {"n": [2]}
        cfg["algorithms"]["fake"]["command"][3] = "{iteration}"  # 1 s, 2 s, 3 s, 4 s
        proc = subprocess.Popen([PY, "-m", "slamq", "run", str(_yaml(tmp_path, cfg)),
                                 "--scheduler", own.address], stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True, env=slamq_env())
        end = time.monotonic() + 60
        while not list((tmp_path / "out").glob("fake/*/seq/*/run.json")):
            assert time.monotonic() < end and proc.poll() is None
            time.sleep(0.05)
        stop(own.scheduler, grace=0)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc is not None and proc.poll() is None:
            proc.kill()
            proc.communicate()
        own.close()
    assert proc.returncode == 2, err
    assert "went away" in err and "finished" in err and "--scheduler" in err
    listing = tmp_path / "out" / "runs-finished.txt"
    assert str(listing) in err
    finished = listing.read_text().split()
    assert finished and all((Path(f) / "run.json").exists() for f in finished)
    # resume here: the finished runs are skipped, the rest run
    rows = runner.execute(cfg)
    assert [r["outcome"] for r in rows] == ["ok"] * 4
    assert sum(1 for r in rows if r.get("skipped")) >= len(finished)


def test_a_worker_without_the_output_folder_returns_the_runs(tmp_path: Path) -> None:
    # the worker runs in its own mount namespace where the output's parent is an empty
    # tmpfs: auto mode sends the run folders back; shared mode records that it cannot
    shared = tmp_path / "shared"
    shared.mkdir()
    if not can_hide(shared):
        pytest.skip("cannot make a private mount namespace here (needs root and unshare)")
    cfg = _config(tmp_path, sleep=0.1, iterations=1)
    cfg["output"] = "shared/out"
    own = Cluster(tmp_path / "dask")
    try:
        own.add_worker("island", hide=shared)
        got = runner.run(cfg, backend=dask_backend(own.address, "auto"))
        assert [r["outcome"] for r in got["rows"]] == ["ok", "ok"]
        for r in got["rows"]:
            folder = Path(r["folder"])
            assert folder.is_relative_to(shared)
            assert (folder / "out" / "map.pgm").exists() and (folder / "run.json").exists()
        assert len(read_results(shared / "out" / "results.jsonl")) == 2
        shutil.rmtree(shared / "out")
        rows = runner.execute(cfg, backend=dask_backend(own.address, "shared"))
    finally:
        own.close()
    assert {r["outcome"] for r in rows} == {"infrastructure"}
    assert "does not see the output folder" in rows[0]["reason"]


def test_a_task_that_waits_for_a_slot_runs_once_a_worker_has_one(tmp_path: Path) -> None:
    # a worker that declares no slamq_run slot gets one from the slots plugin only after it
    # joined; the scheduler does not look at its no-worker tasks again when a worker's
    # resources change, so a run submitted before the slot was known waited forever (seen:
    # test_a_worker_without_the_output_folder_returns_the_runs hung on a loaded machine)
    from distributed import Client

    from slamq.runner.distributed import RESOURCE, _unstick

    own = Cluster(tmp_path / "dask")
    try:
        own.add_worker("bare")
        with Client(own.address, timeout=30) as c:
            fut = c.submit(sum, [1, 2], resources={RESOURCE: 1}, pure=False)
            key = fut.key

            def state(dask_scheduler: object) -> str:
                ts = dask_scheduler.tasks.get(key)  # type: ignore[attr-defined]
                return "not yet" if ts is None else str(ts.state)

            end = time.monotonic() + 30
            while c.run_on_scheduler(state) != "no-worker":
                assert time.monotonic() < end
                time.sleep(0.05)

            async def give_slot(dask_worker: object) -> None:
                await dask_worker.set_resources(**{RESOURCE: 1})  # type: ignore[attr-defined]

            c.run(give_slot)
            time.sleep(0.5)
            assert c.run_on_scheduler(state) == "no-worker"  # dask alone leaves it there
            assert c.run_on_scheduler(_unstick()) == 1
            assert fut.result(timeout=30) == 3
            assert c.run_on_scheduler(_unstick()) == 0
    finally:
        own.close()
