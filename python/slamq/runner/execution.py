"""Stage 3 of a run, executing: the SLAM program started, watched and stopped.

Takes a planned run (:class:`~slamq.runner.planning.RunSpec` and its key) and a parallel
slot; makes its folder, writes the rendered config file and ``env.json``, starts the
command, or the steps of a ROS recipe in order, each in its own session
(:mod:`slamq.runner.process`), waits for each step's readiness, enforces the timeout,
stops the process groups (SIGINT, SIGTERM, SIGKILL), then hands the run to
:func:`slamq.runner.collection.collect`. Gives the run's row (:func:`run_row`: outcome,
reason, exit status, wall/CPU time, peak RSS, collected files), which :func:`run_local`
writes atomically as ``run.json`` (:func:`write_atomic`).

:func:`run_local` runs a list of runs on ``parallel`` local slots; it is the default of
the ``backend`` argument of :func:`slamq.runner.runner.execute` (the Dask backend,
:mod:`slamq.runner.distributed`, runs :func:`execute_one` on workers instead).
"""

from __future__ import annotations

import json
import os
import queue
import shlex
import shutil
import subprocess
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

from slamq.runner import process
from slamq.runner.collection import collect, output_files, outputs_stamp
from slamq.runner.config import Algorithm, RunConfig
from slamq.runner.planning import RunSpec, run_values, slug
from slamq.runner.rendering import render_command, render_config_file, run_env

__all__ = ["OUTCOMES", "execute_one", "run_local", "run_row", "write_atomic"]

#: How a run can end (``outcome`` in ``run.json`` and ``runs.csv``).
OUTCOMES = ("ok", "timeout", "crash", "no_output", "degenerate", "infrastructure")


def write_atomic(path: Path, text: str) -> None:
    """Write ``path`` so that it holds either its old text or all of ``text`` (a temporary
    file, fsync, rename): a run's ``run.json`` is whole or absent, even after ``kill -9``.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "run.json"
    >>> write_atomic(p, "{}"); p.read_text()
    '{}'
    """
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "w") as f:
        f.write(text)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


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
        if kind == "file" and output_files(out, str(value)):
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


def execute_one(spec: RunSpec, key: str, slot: int, config: RunConfig,
                stop: threading.Event) -> dict[str, Any] | None:
    """Run one planned run in a fresh folder on parallel ``slot`` and collect it.

    Returns what :func:`run_row` adds to the row (``outcome``, ``reason``, exit status,
    timings, peak RSS, collected files), or None when ``stop`` was set or the program was
    interrupted (no ``run.json`` then, so a resume runs it again).
    """
    folder = spec.folder
    if folder.exists():
        _stop_leftovers(folder, config)
        shutil.rmtree(folder)
    out = folder / "out"
    out.mkdir(parents=True)
    values = run_values(spec, slot, config)
    algo = spec.algorithm
    cfg = render_config_file(algo, values)
    if cfg is not None:
        Path(values["config"]).write_text(cfg)
    env = run_env(spec.algorithm, values)
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
            argv = render_command(cmd, values, f"algorithms.{algo.name}.command")
            shell = isinstance(argv, str)
            lines.append(argv if shell else shlex.join(argv))
            (folder / "command.txt").write_text("\n".join(lines) + "\n")
            suffix = "" if algo.command is not None else f".{slug(name)}"
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
        outcome, reason, files = collect(spec, config)
        record.update(files, outputs=outputs_stamp(spec))
    elif outcome in ("timeout", "crash"):
        _, _, files = collect(spec, config)  # keep what a failed run left, for a look
        record.update({k: v for k, v in files.items() if k == "snapshots"})
    return {**record, "outcome": outcome, "reason": reason}


#: Outcomes whose program ended well, so that its files can be collected again.
RECOLLECTABLE = ("ok", "no_output", "degenerate")


def recollect(spec: RunSpec, row: dict[str, Any], config: RunConfig) -> dict[str, Any]:
    """``row`` (a finished run's ``run.json``) collected again when its algorithm's
    ``outputs`` changed since (:func:`~slamq.runner.collection.outputs_stamp`; a row from
    before the stamp existed is collected once more): the program is not run again, its
    ``out/`` is read with the new outputs; the new row is written to ``run.json``. Other
    rows are returned as they are."""
    stamp = outputs_stamp(spec)
    if row.get("outcome") not in RECOLLECTABLE or row.get("outputs") == stamp:
        return row
    outcome, reason, files = collect(spec, config)
    new = {k: v for k, v in row.items() if k not in ("map", "trajectory", "snapshots",
                                                     "skipped")}
    new.update(files, outcome=outcome, reason=reason, outputs=stamp)
    write_atomic(spec.folder / "run.json", json.dumps(new, indent=1, default=str))
    return {**new, "skipped": True}


def run_row(spec: RunSpec, key: str, result: dict[str, Any], attempts: int) -> dict[str, Any]:
    """A run's row in ``runs.csv`` and its ``run.json``: where it belongs, its key and
    attempts, then ``result`` (what :func:`execute_one` returned)."""
    return {
        "algorithm": spec.label, "program": spec.algorithm.name, "variant": spec.variant,
        "params": {k: v for k, v in spec.params.items()}, "sequence": spec.sequence.name,
        "iteration": spec.iteration, "folder": str(spec.folder), "key": key,
        "attempts": attempts, **result,
    }


def run_local(config: RunConfig, keyed: list[tuple[RunSpec, str, dict[str, Any]]],
              rows: list[dict[str, Any] | None], todo: list[int], progress: Any = None
              ) -> None:
    """Run ``keyed[i]`` for each ``i`` in ``todo`` on ``config.parallel`` local slots.

    Each finished run's row goes to ``rows[i]``, to its ``run.json`` and to ``progress``
    (when given); a run ending ``infrastructure`` is tried again up to ``config.retries``
    times. Ctrl-C stops every running group (SIGINT, SIGTERM, SIGKILL), then raises
    ``KeyboardInterrupt``; interrupted runs leave no ``run.json``. Called in the main
    thread, a SIGINT or SIGTERM handled in Python (``KeyboardInterrupt``, the ``slamq``
    command's SIGTERM) only asks the runs to stop while they run
    (:func:`slamq.runner.process.interrupts_caught`), so it cannot land half-way through
    starting or stopping them.
    The signature is that of the ``backend`` argument of
    :func:`slamq.runner.runner.execute`.
    """
    slots: queue.Queue[int] = queue.Queue()
    for n in range(config.parallel):
        slots.put(n)

    def work(i: int) -> None:
        if stop.is_set():
            return
        spec, key, pieces = keyed[i]
        slot = slots.get()
        try:
            attempts = 0
            while True:
                attempts += 1
                result = execute_one(spec, key, slot, config, stop)
                if result is None:
                    return
                if result["outcome"] != "infrastructure" or attempts > config.retries:
                    break
            row = run_row(spec, key, result, attempts)
            row["command"] = pieces["command"]
            write_atomic(spec.folder / "run.json", json.dumps(row, indent=1, default=str))
            rows[i] = row
            if progress is not None:
                progress(row)
        finally:
            slots.put(slot)

    # a Ctrl-C (or SIGTERM) sets stop, seen by the runs and here, instead of raising
    # wherever the main thread is: raised inside the pool starting a worker, it left that
    # worker's run unstopped and unwaited for; raised twice, it ended the stopping half-way
    with process.interrupts_caught() as stop:
        pool = ThreadPoolExecutor(max_workers=config.parallel,
                                  thread_name_prefix="slamq-run")
        futures = []
        for i in todo:
            if stop.is_set():
                break
            futures.append(pool.submit(work, i))
        for f in futures:
            while not (f.done() or stop.is_set()):
                time.sleep(0.05)
        pool.shutdown(wait=True, cancel_futures=stop.is_set())
    if stop.is_set():
        raise KeyboardInterrupt
    for f in futures:
        f.result()
