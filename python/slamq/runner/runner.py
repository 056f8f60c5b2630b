"""Run SLAM programs over sequences x iterations x parameter variants, then score them.

Each run gets ``<output>/<algorithm>/<variant>/<sequence>/<iteration>/`` holding
``command.txt``, ``env.json``, ``stdout.log``, ``stderr.log``, the program's own folder
``out/``, the collected ``map.yaml`` (+ image), ``trajectory.tum``, ``snapshots/map_NNNN.yaml``
and ``building.gif``, and ``run.json`` (outcome, exit status, timings, peak RSS, run key),
written atomically last. Outcomes: ``ok``, ``timeout``, ``crash`` (non-zero exit or killed),
``no_output`` (a configured map/trajectory missing or unreadable), ``degenerate`` (no
occupied cell, or fewer than ``min_poses`` poses), ``infrastructure`` (could not start /
a ROS step never became ready, after ``retries``).

Resume: a run whose ``run.json`` holds the same run key (hash of algorithm, resolved
command, rendered config file, params, input content hash, iteration) is not run again;
``retry_failed=True`` reruns the ones that did not end ``ok``.

ROS recipes start their steps in order, each in its own session, waiting for each step's
readiness (a file under ``out/``, a topic listed by ``topic_command``, or a delay); the run
ends when the ``wait`` step ends, then after ``quiet_period`` seconds the other steps are
stopped (SIGINT, SIGTERM, SIGKILL), last started first. Each parallel slot has its own
``ROS_DOMAIN_ID`` (``ros_domain_base + slot``) and ``ROS_MASTER_URI`` port.
"""

from __future__ import annotations

import glob
import hashlib
import json
import os
import queue
import re
import shlex
import shutil
import subprocess
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from slamq.errors import ParamError, SlamqError
from slamq.runner import process
from slamq.runner.config import Algorithm, Output, RunConfig, Sequence, load_config, render
from slamq.synth.benchmark import generate_missing

__all__ = ["RunSpec", "plan", "execute", "run", "run_key"]

OUTCOMES = ("ok", "timeout", "crash", "no_output", "degenerate", "infrastructure")


@dataclass
class RunSpec:
    """One planned run."""

    algorithm: Algorithm
    variant: str
    params: dict[str, Any]
    sequence: Sequence
    iteration: int
    folder: Path

    @property
    def label(self) -> str:
        """The algorithm name used in results: ``name`` or ``name[variant]``."""
        return self.algorithm.name if self.variant == "default" else \
            f"{self.algorithm.name}[{self.variant}]"


_HASHES: dict[str, str] = {}


def input_hash(path: Path) -> str:
    """SHA-1 of a file's bytes or of a folder's files (relative names and bytes)."""
    key = str(path)
    if key in _HASHES:
        return _HASHES[key]
    h = hashlib.sha1(usedforsecurity=False)
    files = [path] if path.is_file() else sorted(p for p in path.rglob("*") if p.is_file())
    if not path.exists():
        raise ParamError(f"{path}: sequence input does not exist")
    for f in files:
        h.update(str(f.relative_to(path) if f != path else f.name).encode() + b"\0")
        with open(f, "rb") as fh:
            for chunk in iter(lambda fh=fh: fh.read(1 << 20), b""):
                h.update(chunk)
    _HASHES[key] = h.hexdigest()
    return _HASHES[key]


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9._=,+-]+", "_", text) or "_"


def plan(config: RunConfig) -> list[RunSpec]:
    """Every run of a configuration, in a stable order (iteration outermost, so parallel
    slots spread over algorithms)."""
    specs = []
    for it in range(1, config.iterations + 1):
        for algo in config.algorithms:
            for variant, params in algo.variants():
                for seq in config.sequences:
                    folder = (config.output / _slug(algo.name) / _slug(variant)
                              / _slug(seq.name) / str(it))
                    specs.append(RunSpec(algo, variant, params, seq, it, folder))
    return specs


def _values(spec: RunSpec, slot: int, config: RunConfig) -> dict[str, Any]:
    out = spec.folder / "out"
    v: dict[str, Any] = {
        "sequence": spec.sequence.name, "input": str(spec.sequence.input), "out": str(out),
        "iteration": spec.iteration, "seed": spec.iteration, "slot": slot,
        "config": str(spec.folder / ("config" + (spec.algorithm.config_template.suffix
                                                 if spec.algorithm.config_template else ""))),
        "ros_domain_id": config.ros_domain_base + slot,
        "ros_master_port": config.ros_master_base + slot,
    }
    v.update({f"param.{k}": val for k, val in spec.params.items()})
    return v


def _render_cmd(cmd: list[str] | str, values: dict[str, Any], where: str) -> list[str] | str:
    if isinstance(cmd, str):
        return render(cmd, values, where)
    return [render(c, values, where) for c in cmd]


def render_config_file(algo: Algorithm, values: dict[str, Any]) -> str | None:
    """The text of the algorithm's config file for one run (template + overrides).

    Overrides are ``SECTION.key`` for ini files (the key's line in that section is replaced;
    a missing key is appended to its section) and dotted paths for YAML files.
    """
    if algo.config_template is None:
        return None
    where = f"algorithms.{algo.name}.config_template"
    try:
        text = algo.config_template.read_text()
    except OSError as exc:
        raise ParamError(f"{algo.config_template}: cannot read {where} "
                         f"({exc.strerror or exc})") from exc
    over = {k: render(str(v), values, f"algorithms.{algo.name}.config_overrides.{k}")
            for k, v in algo.config_overrides.items()}
    if algo.config_template.suffix.lower() in (".yaml", ".yml"):
        import yaml

        doc = yaml.safe_load(text) or {}
        for k, v in over.items():
            node = doc
            parts = k.split(".")
            for p in parts[:-1]:
                node = node.setdefault(p, {})
            node[parts[-1]] = yaml.safe_load(v) if v != "" else v
        return yaml.safe_dump(doc, sort_keys=False)
    return _ini_override(text, over, algo.config_template)


def _ini_override(text: str, over: dict[str, str], where: Path) -> str:
    pending: dict[str, dict[str, str]] = {}
    for k, v in over.items():
        if "." not in k:
            raise ParamError(f"{where}: ini override {k!r} must be SECTION.key")
        sec, key = k.rsplit(".", 1)
        pending.setdefault(sec, {})[key] = v
    lines = text.splitlines()
    out: list[str] = []
    section = None

    def flush(sec: str | None) -> None:
        for key, v in pending.pop(sec, {}).items() if sec is not None else []:
            out.append(f"{key}={v}")

    for line in lines:
        m = re.match(r"\s*\[(.+?)\]", line)
        if m:
            flush(section)
            section = m.group(1)
        else:
            km = re.match(r"\s*([A-Za-z0-9_.\-]+)\s*=", line)
            if km and section in pending and km.group(1) in pending[section]:
                line = f"{km.group(1)}={pending[section].pop(km.group(1))}"
        out.append(line)
    flush(section)
    for sec, keys in pending.items():
        out.append(f"[{sec}]")
        out.extend(f"{k}={v}" for k, v in keys.items())
    return "\n".join(out) + "\n"


def _input_key(seq: Sequence) -> str:
    """What a run key holds of its input: the file's hash; for a generated sequence not made
    yet (a dry run), its recipe's."""
    if seq.generated is not None and not seq.generated.complete():
        blob = json.dumps(seq.generated.recipe, sort_keys=True).encode()
        return "recipe:" + hashlib.sha1(blob, usedforsecurity=False).hexdigest()
    return input_hash(seq.input)


def run_key(spec: RunSpec, config: RunConfig) -> tuple[str, dict[str, Any]]:
    """The run key and the resolved pieces it hashes (slot-independent)."""
    values = _values(spec, 0, config)
    algo = spec.algorithm
    cmd: Any = (_render_cmd(algo.command, values, f"algorithms.{algo.name}.command")
                if algo.command is not None else
                [[s.name, _render_cmd(s.command, values, s.name)] for s in algo.recipe])
    cfg = render_config_file(algo, values)
    pieces = {"algorithm": algo.name, "command": cmd, "config": cfg,
              "params": {k: str(v) for k, v in spec.params.items()},
              "input": _input_key(spec.sequence), "iteration": spec.iteration}
    blob = json.dumps(pieces, sort_keys=True, default=str).encode()
    return hashlib.sha256(blob).hexdigest()[:32], pieces


def _write_atomic(path: Path, text: str) -> None:
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "w") as f:
        f.write(text)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def _glob(out: Path, pattern: str) -> list[Path]:
    return sorted(Path(p) for p in glob.glob(str(out / pattern), recursive=True)
                  if Path(p).is_file() and not p.endswith("_limits.txt"))


def _collect_map(o: Output, src: Path, dest_yaml: Path) -> Path:
    """Make ``dest_yaml`` (map_server YAML) for an output file; returns the map to score."""
    from slamq.sources.maps import load_map

    if o.format == "mrpt":
        from slamq.sources.mrpt import write_mrpt_yaml

        return write_mrpt_yaml(src, dest_yaml)
    if o.format in ("bag", "pbstream"):  # the map drawn, saved as a map_server map: scored,
        from slamq.sources.mapserver import write_raw_map  # shown and reloaded like others

        return write_raw_map(load_map(src, topic=o.topic) if o.format == "bag"
                             else load_map(src), dest_yaml)
    load_map(src)  # readable?
    return src


def _collect(spec: RunSpec, config: RunConfig) -> tuple[str, str, dict[str, Any]]:
    """Collect a finished run's outputs; ``(outcome, reason, files)``."""
    from slamq.sources.maps import load_map

    algo, folder = spec.algorithm, spec.folder
    out = folder / "out"
    files: dict[str, Any] = {}
    if algo.map is not None:
        found = _glob(out, algo.map.path)
        if not found:
            return "no_output", f"no map matching {algo.map.path}", files
        try:
            m = _collect_map(algo.map, found[-1], folder / "map.yaml")
            grid = load_map(m)
        except (SlamqError, OSError) as exc:
            return "no_output", f"map unreadable: {exc}", files
        files["map"] = str(m)
        known = ~grid.unknown
        if not known.any():
            return "degenerate", "the map has no known cell", files
        if not (grid.values[known] < 128).any():
            return "degenerate", "the map has no dark (occupied) cell", files
    if algo.trajectory is not None:
        found = _glob(out, algo.trajectory.path)
        if not found:
            return "no_output", f"no trajectory matching {algo.trajectory.path}", files
        try:
            if algo.trajectory.format == "mrpt":
                from slamq.sources.mrpt import read_mrpt_path

                traj = read_mrpt_path(found[-1])
            else:
                from slamq.sources.trajectories import load_trajectory

                fmt = None if algo.trajectory.format == "auto" else algo.trajectory.format
                traj = load_trajectory(found[-1], format=fmt, topic=algo.trajectory.topic)
            if algo.trajectory.times is not None:
                from slamq.sources.mrpt import apply_step_times

                times = Path(render(algo.trajectory.times, _values(spec, 0, config),
                                    f"algorithms.{algo.name}.outputs.trajectory.times"))
                traj = apply_step_times(traj, times if times.is_absolute() else out / times)
            traj.write_tum(folder / "trajectory.tum")
        except (SlamqError, OSError) as exc:
            return "no_output", f"trajectory unreadable: {exc}", files
        files["trajectory"] = str(folder / "trajectory.tum")
        if len(traj) < config.min_poses:
            return "degenerate", f"{len(traj)} poses (< {config.min_poses})", files
    if algo.snapshots is not None:
        snaps = []
        for i, src in enumerate(_glob(out, algo.snapshots.path), 1):
            try:
                snaps.append(str(_collect_map(algo.snapshots, src,
                                              folder / "snapshots" / f"map_{i:04d}.yaml")))
            except (SlamqError, OSError):
                continue
        files["snapshots"] = len(snaps)
    return "ok", "", files


class _Stop:
    """Shared stop flag and the children alive now (for Ctrl-C)."""

    def __init__(self) -> None:
        self.event = threading.Event()


def _env(spec: RunSpec, values: dict[str, Any]) -> dict[str, str]:
    env = dict(os.environ)
    env["ROS_DOMAIN_ID"] = str(values["ros_domain_id"])
    env["ROS_MASTER_URI"] = f"http://localhost:{values['ros_master_port']}"
    for k, v in spec.algorithm.env.items():
        env[k] = render(v, values, f"algorithms.{spec.algorithm.name}.env.{k}")
    return env


class _NotReady(Exception):
    pass


def _ready(step_ready: dict[str, Any], out: Path, env: dict[str, str], algo: Algorithm,
           child: process.Child, deadline: float, stop: threading.Event) -> None:
    kind, value = next(iter(step_ready.items()))
    if kind == "delay":
        end = time.monotonic() + float(value)
        while time.monotonic() < end and not stop.is_set():
            time.sleep(process.POLL)
        return
    while time.monotonic() < deadline and not stop.is_set():
        if child.poll() is not None:
            raise _NotReady(f"exited ({child.status}) before it was ready")
        if kind == "file" and _glob(out, str(value)):
            return
        if kind == "topic":
            try:
                listed = subprocess.run(algo.topic_command, env=env, capture_output=True,
                                        timeout=10, text=True, stdin=subprocess.DEVNULL).stdout
            except (OSError, subprocess.TimeoutExpired):
                listed = ""
            if str(value) in listed.split():
                return
        time.sleep(0.1 if kind == "file" else 0.5)
    if not stop.is_set():
        raise _NotReady(f"not ready ({kind} {value}) within the startup timeout")


def _stop_leftovers(folder: Path, config: RunConfig) -> None:
    """Stop the process groups an earlier, killed runner left in this run folder.

    A group is stopped only while its leader still works in this run's ``out`` folder
    (``/proc/PID/cwd``), so a reused process id is never signalled.
    """
    groups = folder / "groups.txt"
    if not groups.is_file() or (folder / "run.json").exists():
        return
    out = (folder / "out").resolve()
    for line in groups.read_text().split():
        try:
            pid = int(line)
            cwd = Path(os.readlink(f"/proc/{pid}/cwd")).resolve()
        except (ValueError, OSError):
            continue
        if cwd == out:
            process.stop_group(pid, config.grace)


def _execute_one(spec: RunSpec, key: str, slot: int, config: RunConfig,
                 stop: threading.Event) -> dict[str, Any] | None:
    folder = spec.folder
    if folder.exists():
        _stop_leftovers(folder, config)
        shutil.rmtree(folder)
    out = folder / "out"
    out.mkdir(parents=True)
    values = _values(spec, slot, config)
    algo = spec.algorithm
    cfg = render_config_file(algo, values)
    if cfg is not None:
        Path(values["config"]).write_text(cfg)
    env = _env(spec, values)
    (folder / "env.json").write_text(json.dumps(
        {k: env[k] for k in sorted(env)}, indent=1))
    steps = ([(algo.name, algo.command, None, True)] if algo.command is not None else
             [(s.name, s.command, s.ready, s.wait) for s in algo.recipe])
    lines = []
    started: list[tuple[str, process.Child, bool, Any, Any]] = []
    record: dict[str, Any] = {}
    outcome, reason = "ok", ""
    exit_: process.Exit | None = None
    t0 = time.monotonic()
    try:
        for name, cmd, ready, is_main in steps:
            argv = _render_cmd(cmd, values, f"algorithms.{algo.name}.command")
            shell = isinstance(argv, str)
            lines.append(argv if shell else shlex.join(argv))
            (folder / "command.txt").write_text("\n".join(lines) + "\n")
            suffix = "" if algo.command is not None else f".{_slug(name)}"
            so = open(folder / f"stdout{suffix}.log", "wb")
            se = open(folder / f"stderr{suffix}.log", "wb")
            try:
                child = process.start(argv, cwd=out, env=env, stdout=so, stderr=se, shell=shell)
            except OSError as exc:
                so.close()
                se.close()
                raise _NotReady(f"{name}: cannot start ({exc.strerror or exc})") from exc
            started.append((name, child, is_main, so, se))
            with open(folder / "groups.txt", "a") as f:
                f.write(f"{child.pid}\n")
            if ready:
                _ready(ready, out, env, algo, child,
                       time.monotonic() + config.startup_timeout, stop)
        main = next(c for c in started if c[2])[1]
        remaining = None if config.timeout is None else config.timeout - (time.monotonic() - t0)
        # the main step: its own deadline is what is left of the run's hard cap
        main.started = time.monotonic()
        exit_ = process.wait(main, timeout=None if remaining is None else max(remaining, 0),
                             stop=stop, grace=config.grace)
        if len(started) > 1 and algo.quiet_period and not stop.is_set():
            end = time.monotonic() + algo.quiet_period
            while time.monotonic() < end and not stop.is_set():
                time.sleep(process.POLL)
        for name, child, is_main, _, _ in reversed(started):
            if not is_main:
                early = child.poll()
                process.stop_group(child, config.grace)
                if early not in (None, 0) and outcome == "ok":
                    outcome, reason = "crash", f"{name} exited with {early}"
    except _NotReady as exc:
        for _, child, _, _, _ in reversed(started):
            process.stop_group(child, config.grace)
        if stop.is_set():
            return None
        outcome, reason = "infrastructure", str(exc)
    finally:
        for _, _, _, so, se in started:
            so.close()
            se.close()
    if stop.is_set() or (exit_ is not None and exit_.interrupted):
        return None  # interrupted: no run.json, so a resume runs it again
    if exit_ is not None:
        record.update(returncode=exit_.returncode, wall=round(exit_.wall, 3),
                      user_cpu=exit_.user_cpu, sys_cpu=exit_.sys_cpu,
                      max_rss_kb=exit_.max_rss_kb, stopped_with=exit_.stopped_with)
        if exit_.timed_out:
            outcome, reason = "timeout", f"still running after {config.timeout} s"
        elif exit_.returncode != 0:
            outcome, reason = "crash", f"exit status {exit_.returncode}"
    if outcome == "ok":
        outcome, reason, files = _collect(spec, config)
        record.update(files)
    elif outcome in ("timeout", "crash"):
        _, _, files = _collect(spec, config)  # keep what a failed run left, for a look
        record.update({k: v for k, v in files.items() if k == "snapshots"})
    return {**record, "outcome": outcome, "reason": reason}


def _row(spec: RunSpec, key: str, result: dict[str, Any], attempts: int) -> dict[str, Any]:
    return {
        "algorithm": spec.label, "program": spec.algorithm.name, "variant": spec.variant,
        "params": {k: v for k, v in spec.params.items()}, "sequence": spec.sequence.name,
        "iteration": spec.iteration, "folder": str(spec.folder), "key": key,
        "attempts": attempts, **result,
    }


def execute(config: Any, *, retry_failed: bool = False, dry_run: bool = False,
            progress: Any = None, select: Any = None, backend: Any = None
            ) -> list[dict[str, Any]]:
    """Run (or skip, when finished before) every planned run; returns one row per run.

    Ctrl-C (KeyboardInterrupt in the calling thread) stops every running group (SIGINT,
    SIGTERM, SIGKILL) and is raised again; interrupted runs leave no ``run.json``.
    ``select`` (indices into :func:`plan`) keeps only those runs (a shard); ``backend``
    (``backend(config, keyed, rows, todo, progress)``, e.g. Dask) runs ``todo`` instead of
    the local slots.
    """
    config = load_config(config)
    if not dry_run:
        generate_missing([s.generated for s in config.sequences if s.generated],
                         parallel=config.parallel)
    specs = plan(config)
    if select is not None:
        specs = [specs[i] for i in select]
    keyed = [(s, *run_key(s, config)) for s in specs]
    rows: list[dict[str, Any] | None] = [None] * len(keyed)
    todo = []
    for i, (spec, key, _pieces) in enumerate(keyed):
        done = spec.folder / "run.json"
        old = None
        if done.is_file():
            try:
                old = json.loads(done.read_text())
            except (OSError, ValueError):
                old = None
        if old and old.get("key") == key and (old.get("outcome") == "ok" or not retry_failed):
            rows[i] = {**old, "skipped": True}
        else:
            todo.append(i)
    if dry_run:
        return [{**_row(s, k, {"outcome": "planned"}, 0), "command": p["command"]}
                if rows[i] is None else rows[i]
                for i, (s, k, p) in enumerate(keyed)]
    if backend is not None:
        backend(config, keyed, rows, todo, progress)
        return [r for r in rows if r is not None]
    stop = threading.Event()
    slots: queue.Queue[int] = queue.Queue()
    for n in range(config.parallel):
        slots.put(n)

    def work(i: int) -> None:
        spec, key, pieces = keyed[i]
        slot = slots.get()
        try:
            attempts = 0
            while True:
                attempts += 1
                result = _execute_one(spec, key, slot, config, stop)
                if result is None:
                    return
                if result["outcome"] != "infrastructure" or attempts > config.retries:
                    break
            row = _row(spec, key, result, attempts)
            row["command"] = pieces["command"]
            _write_atomic(spec.folder / "run.json", json.dumps(row, indent=1, default=str))
            rows[i] = row
            if progress is not None:
                progress(row)
        finally:
            slots.put(slot)

    pool = ThreadPoolExecutor(max_workers=config.parallel, thread_name_prefix="slamq-run")
    futures = []
    try:
        # submitted inside the try: a run may start while the pool is still starting its
        # threads, and a Ctrl-C then must stop it too (it escaped the handler before)
        for i in todo:
            futures.append(pool.submit(work, i))
        for f in futures:
            while not f.done():
                time.sleep(0.05)
            f.result()
    except KeyboardInterrupt:
        stop.set()
        with process.held_interrupts():  # a second Ctrl-C must not abandon the stopping
            pool.shutdown(wait=True, cancel_futures=True)  # also one submitted as it came
        raise
    pool.shutdown(wait=True)
    return [r for r in rows if r is not None]


def score(config: RunConfig, rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Score the runs with the batch engine, summarise, write GIFs and the report.

    What did not change since the last call is skipped (:mod:`slamq.runner.cache`): a run
    is scored again only when its map, trajectory, ground truth, place, the ``evaluate``
    settings or slamq's version changed (or its record is missing or failed); a GIF when
    its snapshots changed; the report when any of its inputs did. ``stages`` in the
    result says what was done and skipped, and why (also ``OUTPUT/stages.jsonl``).
    """
    import pandas as pd

    from slamq.batch import Run
    from slamq.results import summarize
    from slamq.results.summary import spreadsheet_safe
    from slamq.runner.cache import Stamps

    seqs = {s.name: s for s in config.sequences}
    runs = []
    for r in rows:
        if r.get("outcome") not in ("ok", "degenerate") or not r.get("map"):
            continue
        seq = seqs.get(r["sequence"])
        runs.append(Run(r["map"], r["algorithm"], r["sequence"], str(r["iteration"]),
                        trajectory=r.get("trajectory"),
                        groundtruth=seq.groundtruth if seq else None,
                        gt_map=seq.groundtruth_map if seq else None))
    out = config.output
    results_path = out / "results.jsonl"
    stamps = Stamps(out)
    stages = []
    scored, run_stamps, stage = _score_changed(config, runs, results_path, stamps)
    stages.append(stage)
    table = pd.DataFrame(rows)
    table.drop(columns=[c for c in ("command", "skipped") if c in table], errors="ignore") \
        .to_csv(out / "runs.csv", index=False)
    summary = None
    if results_path.exists():
        summary = summarize(results_path)
        counts = table.groupby(["algorithm", "sequence"])["outcome"].agg(
            runs="size", ok=lambda s: int((s == "ok").sum()))
        counts["failure_rate"] = 1 - counts["ok"] / counts["runs"]
        summary = summary.merge(counts.reset_index(), on=["algorithm", "sequence"], how="outer")
    from slamq.runner.resources import resource_summary, write_scores

    scores = write_scores(out, rows, results_path)
    if summary is not None:
        summary = resource_summary(summary, scores)
        spreadsheet_safe(summary).to_csv(out / "summary.csv", index=False)
    gifs, snap_stamps, stage = _gifs(rows, stamps, out)
    stages.append(stage)
    report = None
    if config.report and results_path.exists():
        report, stage = _report(config, scores, results_path, stamps, run_stamps,
                                snap_stamps)
        stages.append(stage)
    return {"results": results_path, "records": scored, "summary": summary,
            "gifs": gifs, "report": report, "stages": stages}


def _why(reasons: dict[str, list[str]], limit: int = 3) -> str:
    """``"a: map changed; b: new"`` for the first ``limit`` items, then ``+N more``."""
    items = [f"{k}: {', '.join(v)}" for k, v in reasons.items()]
    more = f"; +{len(items) - limit} more" if len(items) > limit else ""
    return "; ".join(items[:limit]) + more


_INPUT_NAMES = {"new": "not done before", "record": "no stored record (or it failed)",
                "map": "map changed", "trajectory": "trajectory changed",
                "groundtruth": "ground truth changed", "gt_map": "ground-truth map changed",
                "settings": "evaluate settings changed", "version": "slamq version changed",
                "place": "other paths or names", "snapshots": "snapshots changed",
                "gif": "GIF missing", "size": "other frame size"}


def _score_changed(config: RunConfig, runs: list[Any], results_path: Path, stamps: Any
                   ) -> tuple[int, dict[str, Any], dict[str, Any]]:
    """Score the runs whose inputs changed (see :func:`score`); append their records to
    the results file (a re-scored run's old record is replaced). Returns the number scored,
    each run's stamp and the stage's log line."""
    from slamq.batch import evaluate_many
    from slamq.results.store import ResultsFile
    from slamq.runner.cache import changes, file_digest, log_stage, map_digest, stamp
    from slamq.version import __version__

    # what changes a record (not where or how fast it is computed)
    settings = stamp({k: v for k, v in config.evaluate.items()
                      if k not in ("threads", "executor", "chunk_size")})
    digests: dict[str, str | None] = {}

    def once(kind: str, path: Any) -> str | None:
        if path is None:
            return None
        key = f"{kind}:{path}"
        if key not in digests:
            digests[key] = map_digest(path) if kind == "map" else file_digest(path)
        return digests[key]

    stored: set[str] = set()
    if results_path.exists() and runs:
        with ResultsFile(results_path) as rf:
            stored = {json.dumps(list(k)) for k, rec in rf.done()
                      if rec.get("error") in (None, "")}
    run_stamps: dict[str, Any] = {}
    todo, reasons = [], {}
    for run in runs:
        item = json.dumps([str(x) for x in run.key])
        new = {"map": once("map", run.map), "trajectory": once("file", run.trajectory),
               "groundtruth": once("file", run.groundtruth),
               "gt_map": once("map", run.gt_map), "settings": settings,
               "version": __version__,
               "place": stamp([str(x) for x in (*run.key, run.trajectory, run.groundtruth,
                                                 run.gt_map)])}
        run_stamps[item] = new
        why = changes(stamps.get("score", item), new)
        if not why and item not in stored:
            why = ["record"]
        if why:
            todo.append(run)
            reasons[f"{run.algorithm} {run.sequence} #{run.run}"] = [
                _INPUT_NAMES.get(w, w) for w in why]
            stamps.drop("score", item)
    records = 0
    if todo:
        chunk: list[dict[str, Any]] = []
        with ResultsFile(results_path) as rf:
            for rec in evaluate_many(todo, **config.evaluate):
                chunk.append(rec)
                records += 1
                if len(chunk) >= 32:
                    rf.append(chunk)
                    chunk = []
            rf.append(chunk)
        _keep_order(results_path, runs)
        for run in todo:
            item = json.dumps([str(x) for x in run.key])
            stamps.put("score", item, run_stamps[item])
        stamps.save()
    skipped = len(runs) - len(todo)
    message = f"scores: {len(todo)} of {len(runs)} maps scored"
    if todo:
        message += f" ({_why(reasons)})"
    if skipped:
        message += (f"; {skipped} skipped (map, trajectory, ground truth, settings and "
                    "slamq version as when they were scored)")
    stage = log_stage(config.output, "score", len(todo), skipped, message, why=reasons)
    return records, run_stamps, stage


def _need_report_extra(cfg: RunConfig) -> None:
    """The report (``report: true``) draws with matplotlib and Pillow, the ``report`` extra:
    say so before anything runs."""
    import importlib.util

    missing = [m for m in ("matplotlib", "PIL") if importlib.util.find_spec(m) is None]
    if missing:
        raise SlamqError(f"{cfg.source}: report: true needs the 'report' extra "
                         f"({', '.join(missing)} not installed): pip install 'slamq[report]', "
                         "or set report: false")


def _keep_order(results_path: Path, runs: list[Any]) -> None:
    """Put the records of ``results_path`` (JSON Lines) back in the order of ``runs`` (a
    re-scored run's record was appended last), so that the report's pages keep their
    names; records of runs not planned any more stay, after them. Rewritten atomically,
    only when the order changed."""
    from slamq.results.formats import dumps_record, iter_jsonl

    order = {tuple(str(x) for x in r.key): i for i, r in enumerate(runs)}
    records = list(iter_jsonl(results_path))

    def position(ir: tuple[int, dict[str, Any]]) -> tuple[int, int]:
        i, rec = ir
        key = tuple(str(rec.get(k)) for k in ("algorithm", "sequence", "run", "map"))
        return (order[key], 0) if key in order else (len(order), i)

    ranked = sorted(enumerate(records), key=position)
    if [i for i, _ in ranked] == list(range(len(records))):
        return
    tmp = results_path.with_name(results_path.name + ".tmp")
    with open(tmp, "w", encoding="utf-8") as f:
        f.write("".join(dumps_record(rec) for _, rec in ranked))
    os.replace(tmp, results_path)


def _gifs(rows: list[dict[str, Any]], stamps: Any, output: Path
          ) -> tuple[list[Path], dict[str, Any], dict[str, Any]]:
    """A ``building.gif`` per run from its collected snapshots (the report's renderer),
    made again only when its snapshots changed; none without Pillow (the ``report``
    extra). Returns the GIFs, each run's snapshot stamp and the stage's log line."""
    import importlib.util

    from slamq.runner.cache import changes, log_stage, snapshots_digest
    from slamq.version import __version__

    made: list[Path] = []
    snap_stamps: dict[str, Any] = {}
    if importlib.util.find_spec("PIL") is None:
        stage = log_stage(output, "gifs", 0, 0, "GIFs: none (Pillow is not installed)")
        return made, snap_stamps, stage
    from slamq.report.animation import render_frames, write_gif
    from slamq.sources.maps import load_map
    from slamq.sources.snapshots import find_snapshots

    drawn, kept, reasons = 0, 0, {}
    for r in rows:
        folder = Path(r["folder"])
        gif = folder / "building.gif"
        digest = snapshots_digest(folder)
        snap_stamps[str(folder)] = digest
        if digest is None:
            continue
        new = {"snapshots": digest, "size": 400, "version": __version__}
        why = changes(stamps.get("gif", str(folder)), new)
        if not why and not gif.exists():
            why = ["gif"]
        if not why:
            made.append(gif)
            kept += 1
            continue
        stamps.drop("gif", str(folder))
        reasons[f"{r['algorithm']} {r['sequence']} #{r['iteration']}"] = [
            _INPUT_NAMES.get(w, w) for w in why]
        try:
            maps = [load_map(p) for p in find_snapshots(folder)]
            made.append(write_gif(render_frames(maps, max_size=400), gif))
        except (SlamqError, OSError):
            continue
        stamps.put("gif", str(folder), new)
        drawn += 1
    if drawn:
        stamps.save()
    message = f"GIFs: {drawn} of {drawn + kept} made"
    if reasons:
        message += f" ({_why(reasons)})"
    if kept:
        message += f"; {kept} skipped (snapshots as when they were drawn)"
    stage = log_stage(output, "gifs", drawn, kept, message, why=reasons)
    return made, snap_stamps, stage


def _report(config: RunConfig, scores: Any, results_path: Path, stamps: Any,
            run_stamps: dict[str, Any], snap_stamps: dict[str, Any]
            ) -> tuple[Path, dict[str, Any]]:
    """Write the report, or skip it when none of its inputs changed since it was written
    (and ``report/index.html`` is that file)."""
    from slamq.report import build_report
    from slamq.report.resources import resources_page
    from slamq.runner.cache import changes, file_digest, log_stage, stamp
    from slamq.version import __version__

    out = config.output
    index = out / "report" / "index.html"
    title = "slamq run report"
    new = {"results": file_digest(results_path), "scores": file_digest(out / "scores.csv"),
           "runs": stamp(run_stamps), "snapshots": stamp(snap_stamps), "title": title,
           "version": __version__}
    old = stamps.get("report", "report")
    why = changes(old.get("inputs") if isinstance(old, dict) else None, new)
    if not why and (not index.is_file() or file_digest(index) != old.get("index")):
        why = ["index"]
    if not why:
        stage = log_stage(out, "report", 0, 1, "report: skipped (results, scores, maps, "
                          "snapshots and slamq version as when it was written)")
        return index, stage
    names = {"results": "results changed", "scores": "scores.csv changed",
             "runs": "a map, trajectory or ground truth changed",
             "snapshots": "snapshots changed", "index": "report/index.html missing or "
             "edited", "new": "not written before", "version": "slamq version changed",
             "title": "other title"}
    stamps.drop("report", "report")
    stamps.save()
    report = build_report(results_path, out / "report", title=title, reuse=True)
    resources_page(scores, out / "report")
    stamps.put("report", "report", {"inputs": new, "index": file_digest(report)})
    stamps.save()
    try:  # how many detail pages build_report drew and kept
        pages = json.loads((out / "report" / ".pages.json").read_text())
        drawn, reused = int(pages["drawn"]), int(pages["reused"])
    except (OSError, ValueError, KeyError, TypeError):
        drawn, reused = 0, 0
    message = (f"report: written ({', '.join(names.get(w, w) for w in why)}); "
               f"detail pages: {drawn} drawn, {reused} kept (record, map, trajectory, "
               "ground truth and snapshots as when they were drawn)")
    return report, log_stage(out, "report", 1, 0, message, why=why, pages_drawn=drawn,
                             pages_kept=reused)


def run(config: Any, *, retry_failed: bool = False, dry_run: bool = False,
        progress: Any = None, backend: Any = None) -> dict[str, Any]:
    """Run a configuration end to end: the runs, the scores, the summary, GIFs, the report.

    Parameters
    ----------
    config : path, dict or RunConfig
        See :mod:`slamq.runner.config`.
    retry_failed : bool
        Run again the finished runs whose outcome was not ``ok``.
    dry_run : bool
        Only plan: the rows say ``planned`` (or the stored outcome) with their commands.
    backend : callable, optional
        Where the runs go instead of the local slots (see :func:`execute`;
        :func:`slamq.runner.distributed.dask_backend`).

    Returns
    -------
    dict
        ``rows`` (one per run), ``results`` (the batch results file), ``summary``
        (DataFrame: mean ± std per algorithm[variant] and sequence, plus ``runs``, ``ok``,
        ``failure_rate``), ``gifs``, ``report`` (index.html or None), ``records`` (maps
        scored now), ``stages`` (per stage: ``done``, ``skipped``, ``message`` saying why;
        see :func:`score`).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp()); _ = (d / "in.txt").write_text("x")
    >>> r = run({"base_dir": str(d), "output": "o", "sequences": {"s": "in.txt"},
    ...          "algorithms": {"echo": {"command": ["echo", "{input}"]}}}, dry_run=True)
    >>> [row["outcome"] for row in r["rows"]]
    ['planned']
    """
    cfg = load_config(config)
    if cfg.report and not dry_run:
        _need_report_extra(cfg)  # before the runs, not after hours of them
    rows = execute(cfg, retry_failed=retry_failed, dry_run=dry_run, progress=progress,
                   backend=backend)
    if dry_run:
        return {"rows": rows, "results": None, "summary": None, "gifs": [], "report": None}
    cfg.output.mkdir(parents=True, exist_ok=True)
    return {"rows": rows, **score(cfg, rows)}
