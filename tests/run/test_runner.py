"""The runner with ordinary commands: outcomes, timeouts, Ctrl-C, resume, ROS-style recipes."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
import uuid
from pathlib import Path

import numpy as np
import pytest

from slamq.runner import runner
from slamq.runner.rendering import render_config_file

PY = sys.executable


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    # a zombie is not alive for our purpose
    try:
        return Path(f"/proc/{pid}/stat").read_text().split()[2] != "Z"
    except OSError:
        return False


def _running(argv: list[str]) -> list[int]:
    """The live (not zombie) processes whose command line is exactly ``argv``."""
    want = ("\0".join(argv) + "\0").encode()
    found = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                if (d / "cmdline").read_bytes() == want and _alive(int(d.name)):
                    found.append(int(d.name))
            except OSError:
                continue
    return found


def _config(tmp_path: Path, algorithms: dict, **extra) -> dict:
    (tmp_path / "in.txt").write_text("input\n")
    return {"base_dir": str(tmp_path), "output": "out", "sequences": {"seq": "in.txt"},
            "algorithms": algorithms, "report": False, "grace": [0.5, 0.5], **extra}


def test_timeout_of_a_command_that_ignores_sigint_kills_the_group(tmp_path: Path) -> None:
    # the shell ignores SIGINT and leaves a background child: both must be gone afterwards
    cmd = "trap '' INT; sleep 60 & echo $! > {out}/child.pid; echo $$ > {out}/sh.pid; wait"
    cfg = _config(tmp_path, {"stubborn": {"command": cmd}}, timeout=1.0)
    t0 = time.monotonic()
    rows = runner.execute(cfg)
    assert time.monotonic() - t0 < 10
    (row,) = rows
    assert row["outcome"] == "timeout"
    assert row["stopped_with"] in ("SIGTERM", "SIGKILL")
    out = Path(row["folder"]) / "out"
    for name in ("child.pid", "sh.pid"):
        assert not _alive(int((out / name).read_text())), name
    stored = json.loads((Path(row["folder"]) / "run.json").read_text())
    assert stored["outcome"] == "timeout" and stored["wall"] >= 1.0


def test_crash_and_missing_output_are_result_rows(tmp_path: Path) -> None:
    cfg = _config(tmp_path, {
        "crasher": {"command": ["sh", "-c", "echo boom >&2; exit 3"],
                    "outputs": {"map": {"path": "*.pgm", "format": "image"}}},
        "silent": {"command": ["true"], "outputs": {"map": {"path": "*.pgm", "format": "image"}}},
    })
    rows = {r["algorithm"]: r for r in runner.execute(cfg)}
    assert rows["crasher"]["outcome"] == "crash" and rows["crasher"]["returncode"] == 3
    assert "boom" in (Path(rows["crasher"]["folder"]) / "stderr.log").read_text()
    assert rows["silent"]["outcome"] == "no_output"
    assert "no map" in rows["silent"]["reason"]
    assert rows["silent"]["user_cpu"] >= 0 and rows["silent"]["max_rss_kb"] > 0


def test_ok_run_is_scored_and_resumed_and_retry_failed(tmp_path: Path) -> None:
    # a "SLAM" that writes a map image; params sweep; counts its own invocations
    script = tmp_path / "slam.py"
    script.write_text(
        "import sys, numpy as np, cv2, pathlib\n"
        "out = pathlib.Path(sys.argv[1]); n = int(sys.argv[2])\n"
        "with open(pathlib.Path(sys.argv[3]), 'a') as f: f.write('x')\n"
        "img = np.full((40, 40), 254, np.uint8); img[5:5 + n, 5:35] = 0\n"
        "cv2.imwrite(str(out / 'map.pgm'), img)\n"
        "(out / 'traj.txt').write_text(''.join(f'{i} {i + 0.1 * n} 0 0 0 0 0 1\\n' "
        "for i in range(5)))\n")
    (tmp_path / "gt.txt").write_text("".join(f"{i} {i} 0 0 0 0 0 1\n" for i in range(5)))
    counter = tmp_path / "count"
    cfg = _config(tmp_path, {"fake": {
        "command": [PY, str(script), "{out}", "{param.n}", str(counter)],
        "params": {"n": [2, 4]},
        "outputs": {"map": {"path": "map.pgm", "format": "image"},
                    "trajectory": {"path": "traj.txt", "format": "tum"}}}},
        iterations=2, parallel=2)
    cfg["sequences"] = {"seq": {"input": "in.txt", "groundtruth": "gt.txt"}}
    result = runner.run(cfg)
    assert [r["outcome"] for r in result["rows"]] == ["ok"] * 4
    assert counter.read_text() == "x" * 4
    summary = result["summary"]
    assert set(summary["algorithm"]) == {"fake[n=2]", "fake[n=4]"}
    assert (summary["n"] == 2).all() and (summary["failure_rate"] == 0).all()
    # ATE against the sequence's ground truth (se2 alignment removes a constant offset)
    assert summary["ate_rmse_mean"].tolist() == pytest.approx([0.0, 0.0], abs=1e-9)
    assert (tmp_path / "out" / "runs.csv").exists() and (tmp_path / "out" / "summary.csv").exists()
    again = runner.execute(cfg)
    assert counter.read_text() == "x" * 4 and all(r.get("skipped") for r in again)
    # a failed run is kept unless --retry-failed
    one = Path(result["rows"][0]["folder"]) / "run.json"
    rec = json.loads(one.read_text())
    rec["outcome"] = "crash"
    one.write_text(json.dumps(rec))
    runner.execute(cfg)
    assert counter.read_text() == "x" * 4
    runner.execute(cfg, retry_failed=True)
    assert counter.read_text() == "x" * 5


def _cli(args: list[str], **kw) -> subprocess.Popen:
    return subprocess.Popen([PY, "-m", "slamq", *args], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, **kw)


def _yaml(tmp_path: Path, cfg: dict) -> Path:
    import yaml

    cfg = dict(cfg)
    cfg.pop("base_dir")
    p = tmp_path / "run.yaml"
    p.write_text(yaml.safe_dump(cfg))
    return p


def _wait_for(path: Path, seconds: float = 20) -> None:
    end = time.monotonic() + seconds
    while not (path.exists() and path.read_text().strip()):
        assert time.monotonic() < end, f"{path} never appeared"
        time.sleep(0.05)


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["ctrl-c", "sigterm"])
def test_ctrl_c_or_sigterm_of_slamq_run_stops_every_group(tmp_path: Path, sig: int) -> None:
    # SIGTERM is what a batch scheduler sends at its time limit or on preemption
    cfg = _config(tmp_path, {"sleeper": {
        "command": "sleep 60 & echo $! > {out}/child.pid; wait"}}, parallel=1)
    proc = _cli(["run", str(_yaml(tmp_path, cfg))])
    pid_file = tmp_path / "out" / "sleeper" / "default" / "seq" / "1" / "out" / "child.pid"
    _wait_for(pid_file)
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=20)
    assert proc.returncode == 130, err
    assert "interrupted" in err
    assert not _alive(int(pid_file.read_text()))
    assert not (pid_file.parent.parent / "run.json").exists()


@pytest.mark.parametrize("signals, runs", [("INT", 3), ("INT TERM " * 10, 12)])
def test_a_ctrl_c_as_the_runs_start_stops_every_run(tmp_path: Path, signals: str,
                                                     runs: int) -> None:
    # Each command sends the Ctrl-C (or a scheduler's SIGTERM) itself once its child is
    # up: to slamq, its meter's parent. A Ctrl-C that came while the pool was still
    # starting its threads used to be lost (the runs went on to their end), then, raised
    # inside a thread's start, left that thread's run unstopped (seen once in CI, 3 runs);
    # wherever it lands now, every run is stopped. 12 runs at once keep the pool starting
    # threads as the signals come, each run's signals (a burst of 20) arriving while
    # others are stopped.
    # The pid file is written whole (a run stopped between the shell opening it and
    # writing to it left it empty), and the sleep's unique length finds the children
    # whose pid was never written.
    length = f"60.{uuid.uuid4().int % 10**9:09d}"
    cmd = (f"sleep {length} & echo $! > {{out}}/child.tmp && mv {{out}}/child.tmp "
           "{out}/child.pid; p=$(cut -d' ' -f4 /proc/$PPID/stat); "
           f"for s in {signals}; do kill -$s $p; done; wait")
    cfg = _config(tmp_path, {f"r{k}": {"command": cmd} for k in range(runs)},
                  parallel=runs)
    t0 = time.monotonic()
    proc = _cli(["run", str(_yaml(tmp_path, cfg))])
    _, err = proc.communicate(timeout=40)
    assert proc.returncode == 130, err
    assert time.monotonic() - t0 < 30, "the runs went on after the Ctrl-C"
    pids = list((tmp_path / "out").glob("*/default/seq/1/out/child.pid"))
    assert pids, err  # at least the run that sent the Ctrl-C had started
    for pid_file in pids:
        assert not _alive(int(pid_file.read_text())), pid_file
        assert not (pid_file.parent.parent / "run.json").exists()
    assert not _running(["sleep", length]), "a run's child outlived slamq run"


def test_a_signal_to_slamq_and_its_runs_at_once_leaves_the_runs_unfinished(
        tmp_path: Path) -> None:
    # As a batch scheduler stops a job (Slurm's scancel, a requeue): SIGTERM to every
    # process of it, slamq and its runs' programs alike. The run whose program the signal
    # killed is interrupted, not a crash: no run.json, so the shard's next start runs it
    # again. (Seen in CI: with the stop set by the main thread 50 ms late, the run saw its
    # program end first and was recorded as a crash, and a requeued task skipped it.)
    cfg = _config(tmp_path, {"a": {"command": "echo up > {out}/up; "
                                              "while true; do sleep 0.05; done"}})
    proc = _cli(["run", str(_yaml(tmp_path, cfg))])
    folder = tmp_path / "out" / "a" / "default" / "seq" / "1"
    try:
        _wait_for(folder / "out" / "up")
        group = int((folder / "groups.txt").read_text().split()[0])
        os.kill(proc.pid, signal.SIGTERM)
        os.killpg(group, signal.SIGTERM)
        _, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, err
    assert not (folder / "run.json").exists(), (folder / "run.json").read_text()


def test_slamq_run_reaps_what_a_stopped_run_left_without_waiting_for_init(
        tmp_path: Path) -> None:
    # The shell dies at the SIGINT, its `sleep` (SIGINT ignored, as a background job)
    # at the SIGTERM 0.5 s later. The sleep was an orphan: reparented to init, its zombie
    # kept the group alive until init reaped it (1-2 s on this machine, never when slamq
    # is a container's PID 1), so the stop went on to SIGKILL and its 2 s grace. slamq run
    # adopts the orphans of its runs and reaps them: the group is gone at the SIGTERM.
    cfg = _config(tmp_path, {"orphaner": {
        "command": "sleep 60 & echo $! > {out}/child.pid; wait"}}, timeout=1.0)
    proc = _cli(["run", str(_yaml(tmp_path, cfg))])
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    folder = tmp_path / "out" / "orphaner" / "default" / "seq" / "1"
    row = json.loads((folder / "run.json").read_text())
    assert row["outcome"] == "timeout", row
    assert row["stopped_with"] == "SIGTERM", row
    assert not _alive(int((folder / "out" / "child.pid").read_text()))


def test_resume_after_sigkill(tmp_path: Path) -> None:
    counter = tmp_path / "count"
    cfg = _config(tmp_path, {
        "fast": {"command": f"echo x >> {counter}"},
        "slow": {"command": "sleep 60 & echo $! > {out}/child.pid; wait"}}, parallel=1)
    proc = _cli(["run", str(_yaml(tmp_path, cfg))])
    pid_file = tmp_path / "out" / "slow" / "default" / "seq" / "1" / "out" / "child.pid"
    _wait_for(pid_file)
    proc.kill()
    proc.wait(timeout=10)
    child = int(pid_file.read_text())
    assert _alive(child)  # the killed runner could not stop its run's own session
    fast = tmp_path / "out" / "fast" / "default" / "seq" / "1" / "run.json"
    assert json.loads(fast.read_text())["outcome"] == "ok"
    assert not (pid_file.parent.parent / "run.json").exists()
    cfg["algorithms"]["slow"]["command"] = "true"
    rows = runner.execute(cfg)
    assert not _alive(child)  # the resumed run stopped what the killed runner left
    assert counter.read_text() == "x\n"  # fast was not run again
    assert {r["algorithm"]: r["outcome"] for r in rows} == {"fast": "ok", "slow": "ok"}


def test_recipe_steps_in_order_with_readiness_and_per_slot_env(tmp_path: Path) -> None:
    recipe = [
        {"name": "slam", "command": "echo $ROS_DOMAIN_ID > {out}/domain; sleep 0.3; "
                                    "touch {out}/ready.flag; trap 'echo stopped > {out}/slam.end;"
                                    " exit 0' INT; while true; do sleep 0.05; done",
         "ready": {"file": "ready.flag"}},
        {"name": "record", "command": "trap 'exit 0' INT; echo rec > {out}/rec; "
                                      "while true; do sleep 0.05; done",
         "ready": {"delay": 0.2}},
        {"name": "play", "command": "test -f {out}/rec && echo played > {out}/played",
         "wait": True},
    ]
    cfg = _config(tmp_path, {"ros": {"recipe": recipe, "quiet_period": 0.2}},
                  ros_domain_base=40, parallel=1)
    (row,) = runner.execute(cfg)
    out = Path(row["folder"]) / "out"
    assert row["outcome"] == "ok", row
    assert (out / "played").read_text().strip() == "played"
    assert (out / "slam.end").read_text().strip() == "stopped"  # SIGINT first, not SIGKILL
    assert (out / "domain").read_text().strip() == "40"


def test_recipe_never_ready_is_an_infrastructure_failure_retried(tmp_path: Path) -> None:
    counter = tmp_path / "count"
    recipe = [{"name": "slam", "command": f"echo x >> {counter}; sleep 30",
               "ready": {"file": "never"}},
              {"name": "play", "command": "true"}]
    cfg = _config(tmp_path, {"ros": {"recipe": recipe}}, startup_timeout=0.5, retries=1)
    (row,) = runner.execute(cfg)
    assert row["outcome"] == "infrastructure" and row["attempts"] == 2
    assert counter.read_text() == "x\nx\n"


def test_bad_config_names_the_file(tmp_path: Path) -> None:
    p = tmp_path / "bad.yaml"
    p.write_text("sequences: {s: in.txt}\nalgorithms: {a: {command: [x], bogus: 1}}\n")
    proc = _cli(["run", str(p)])
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 2 and "bad.yaml" in err and "bogus" in err


def test_typos_in_a_run_config_are_refused_with_the_closest_name(tmp_path: Path) -> None:
    """Issue 42, point 2: a misspelt override section added a new ini section and the
    program ran with the template's value; a misspelt output key was ignored. Both, and
    unknown keys at every level, are refused with the closest known name."""
    from slamq.errors import ParamError
    from slamq.runner.config import load_config

    ini = tmp_path / "t.ini"
    ini.write_text("[MappingApplication]\nsampleSize=5\nlogOutput_dir=x\n")
    (tmp_path / "in.txt").write_text("x")

    def cfg(**algo: object) -> dict:
        return {"base_dir": str(tmp_path), "sequences": {"s": {"input": "in.txt"}},
                "algorithms": {"a": {"command": ["true"], **algo}}}

    cases = [
        (cfg(config_template="t.ini", config_overrides={"MappingAplication.sampleSize": 10}),
         "no section [MappingAplication] (did you mean MappingApplication.sampleSize?"),
        (cfg(config_template="t.ini", config_overrides={"MappingApplication.sampleSze": 10}),
         "no key sampleSze (did you mean MappingApplication.sampleSize?)"),
        (cfg(outputs={"map": {"path": "m.pgm", "fromat": "image"}}),
         "outputs.map: unknown key 'fromat' (did you mean 'format'?)"),
        (cfg(outptus={"map": "m.pgm"}), "unknown key 'outptus' (did you mean 'outputs'?)"),
        ({**cfg(), "iteratons": 3}, "unknown key 'iteratons' (did you mean 'iterations'?)"),
        ({**cfg(), "sequences": {"s": {"input": "in.txt", "grondtruth": "g.txt"}}},
         "sequences.s: unknown key 'grondtruth' (did you mean 'groundtruth'?)"),
    ]
    for doc, message in cases:
        with pytest.raises(ParamError, match=re.escape(message)):
            load_config(doc)
    # a key the section lacks that resembles none is added (programs read optional keys),
    # and +SECTION.key adds a section on purpose
    ok = load_config(cfg(config_template="t.ini", config_overrides={
        "MappingApplication.RANDOM_SEED": 3, "+Extra.resolution": 0.05}))
    text = render_config_file(ok.algorithms[0], {})
    assert "RANDOM_SEED=3" in text and "[Extra]\nresolution=0.05" in text


def test_a_finished_run_leaves_no_background_child(tmp_path: Path) -> None:
    cfg = _config(tmp_path, {"leaky": {
        "command": "trap '' INT; sleep 60 & echo $! > {out}/child.pid; exit 0"}})
    (row,) = runner.execute(cfg)
    assert row["outcome"] == "ok" and row["stopped_with"] in ("SIGTERM", "SIGKILL")
    assert not _alive(int((Path(row["folder"]) / "out" / "child.pid").read_text()))


def test_dry_run_plans_without_running(tmp_path: Path) -> None:
    counter = tmp_path / "count"
    cfg = _config(tmp_path, {"a": {"command": ["sh", "-c", f"echo x >> {counter}", "{param.n}"],
                                   "params": {"n": [1, 2]}}}, iterations=2)
    proc = _cli(["run", str(_yaml(tmp_path, cfg)), "--dry-run"])
    out, err = proc.communicate(timeout=30)
    assert proc.returncode == 0, err
    assert out.count("planned") == 4 and "a[n=2]" in out
    assert not counter.exists() and not (tmp_path / "out").exists()


def test_a_cartographer_pbstream_output_is_rasterised_and_scored(tmp_path: Path) -> None:
    # a "Cartographer" writing a pbstream with one 2D submap (the encoder of the tests)
    from _pbencode import graph, grid2d, submap, write

    cells = np.full((30, 40), 32767, np.int64)  # free, p = 0.1
    cells[10:12, 5:35] = 1  # a wall, p = 0.9
    folder = tmp_path / "stream"
    folder.mkdir()
    made = write(folder, graph({0: (0, 0, 0)}),
                 submap(0, 0, (0, 0, 0), grid2d(cells, (3.0, 2.0), (0, 0, 39, 29))))
    cfg = _config(tmp_path, {"cartographer": {
        "command": ["cp", str(made), "{out}/map.pbstream"],
        "outputs": {"map": {"path": "map.pbstream", "format": "pbstream"}}}})
    result = runner.run(cfg)
    assert [r["outcome"] for r in result["rows"]] == ["ok"], result["rows"]
    from slamq.results import read_results

    rec = read_results(tmp_path / "out" / "results.jsonl").iloc[0]
    assert rec["error"] is None or rec["error"] != rec["error"]  # None or NaN
    assert rec["known"] == 30 * 40 and rec["occupied"] == 2 * 30
    # collected as a map_server map (mode raw) that loads back to the rasterised grid
    assert rec["map"].endswith("map.yaml")
    from slamq import load_map

    a, b = load_map(rec["map"]), load_map(folder / "map.pbstream")
    assert (a.values == b.values).all() and (a.unknown == b.unknown).all()
    assert a.origin == b.origin and a.resolution == b.resolution


def test_a_bag_map_output_on_its_own_topic_is_collected_and_scored(tmp_path: Path) -> None:
    from _bagdata import BagWriter, room_grid

    made = tmp_path / "made.bag"
    with BagWriter(made, "ros1") as w:  # the map on a topic that is not /map
        w.write("/slam/map", "nav_msgs/msg/OccupancyGrid", w.grid(1.0, room_grid(size=30)))
    cfg = _config(tmp_path, {"slam": {
        "command": ["cp", str(made), "{out}/rec.bag"],
        "outputs": {"map": {"path": "rec.bag", "format": "bag", "topic": "/slam/map"}}}})
    result = runner.run(cfg)
    assert [r["outcome"] for r in result["rows"]] == ["ok"], result["rows"]
    from slamq import load_map
    from slamq.results import read_results

    rec = read_results(tmp_path / "out" / "results.jsonl").iloc[0]
    assert not isinstance(rec["error"], str), rec["error"]
    expected = load_map(made, topic="/slam/map")
    assert rec["known"] == expected.known_count and rec["map"].endswith("map.yaml")


def test_an_index_timed_trajectory_gets_its_times_from_a_file(tmp_path: Path) -> None:
    # icp-slam style "step x y yaw" rows; the times come from {input}.steps.txt
    script = tmp_path / "slam.py"
    script.write_text(
        "import sys, numpy as np, cv2, pathlib\n"
        "out = pathlib.Path(sys.argv[1])\n"
        "img = np.full((40, 40), 254, np.uint8); img[5:8, 5:35] = 0\n"
        "cv2.imwrite(str(out / 'map.pgm'), img)\n"
        "(out / 'log.txt').write_text(''.join(f'{i} {0.5 * i} 0 0\\n' for i in range(4)))\n")
    (tmp_path / "in.txt.steps.txt").write_text("".join(f"{100 + i}.0\n" for i in range(4)))
    (tmp_path / "gt.txt").write_text("".join(f"{100 + i} {0.5 * i} 0 0 0 0 0 1\n"
                                             for i in range(4)))
    cfg = _config(tmp_path, {"icp": {
        "command": [PY, str(script), "{out}"],
        "outputs": {"map": {"path": "map.pgm", "format": "image"},
                    "trajectory": {"path": "log.txt", "format": "mrpt",
                                   "times": "{input}.steps.txt"}}}})
    cfg["sequences"] = {"seq": {"input": "in.txt", "groundtruth": "gt.txt"}}
    result = runner.run(cfg)
    assert [r["outcome"] for r in result["rows"]] == ["ok"]
    tum = np.loadtxt(Path(result["rows"][0]["folder"]) / "trajectory.tum")
    assert tum[:, 0].tolist() == [100.0, 101.0, 102.0, 103.0]
    from slamq.results import read_results

    rec = read_results(tmp_path / "out" / "results.jsonl").iloc[0]
    assert rec["ate_n"] == 4 and rec["ate_rmse"] == pytest.approx(0.0, abs=1e-9)
    cfg["algorithms"]["icp"]["outputs"]["trajectory"]["times"] = 5
    with pytest.raises(Exception, match=r"outputs.trajectory.times must be a path"):
        runner.run(cfg)


def test_a_report_without_the_report_extra_is_refused_before_any_run(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # matplotlib and Pillow hidden as on a plain `pip install .`; the runs would take hours
    # before the report failed
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name in ("matplotlib", "PIL") else
                        real(name, *a))
    counter = tmp_path / "count"
    cfg = _config(tmp_path, {"fast": {"command": f"echo x >> {counter}"}}, parallel=1)
    cfg["report"] = True
    from slamq.errors import SlamqError

    with pytest.raises(SlamqError, match=r"pip install 'slamq\[report\]', or set report"):
        runner.run(cfg)
    assert not counter.exists()
    cfg["report"] = False  # runs and scores; no GIFs without Pillow
    assert [r["outcome"] for r in runner.run(cfg)["rows"]] == ["ok"]


def test_the_stages_import_only_the_stages_before_them() -> None:
    """A run goes config -> planning (with rendering, which its key hashes) -> execution ->
    collection -> scoring; each stage module imports only the runner modules it builds on,
    and ``runner`` (the orchestrator) holds no stage's work."""
    import ast
    import importlib
    import inspect

    allowed = {
        "rendering": {"config"},
        "planning": {"config", "rendering"},
        "collection": {"config", "planning"},
        "execution": {"config", "planning", "rendering", "collection", "process"},
        "scoring": {"config", "cache", "resources"},
        "runner": {"config", "planning", "rendering", "execution", "scoring"},
    }
    for stage, ok in allowed.items():
        path = inspect.getfile(importlib.import_module(f"slamq.runner.{stage}"))
        tree = ast.parse(Path(path).read_text(encoding="utf-8"))
        used = set()
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module:
                if node.module == "slamq.runner":
                    used.update(a.name for a in node.names)
                elif node.module.startswith("slamq.runner."):
                    used.add(node.module.split(".")[2])
        assert used <= ok, f"slamq.runner.{stage} imports {sorted(used - ok)}"
    runner_defs = [n.name for n in ast.parse(Path(runner.__file__).read_text()).body
                   if isinstance(n, ast.FunctionDef)]
    assert runner_defs == ["execute", "run"]
