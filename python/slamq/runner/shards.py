"""Array jobs without Dask: ``slamq run CONFIG --shard I/N`` and ``--merge``.

The planned runs (:func:`slamq.runner.planning.plan`, a stable order) are dealt round-robin
into N slices: shard I (0-based) takes the runs ``I, I+N, I+2N, ...``, so every algorithm,
variant and iteration is spread over the shards. ``--shard N`` alone takes I from
``JOB_COMPLETION_INDEX`` (a Kubernetes Indexed Job, 0-based) or else from
``SLURM_ARRAY_TASK_ID - SLURM_ARRAY_TASK_MIN`` (a Slurm array, any base).

A shard runs its slice like a local run (``parallel`` slots, resume, ``run.json`` per run in
the shared output folder) and scores nothing. ``--merge`` reads every planned run's
``run.json`` (the run key must match) and scores the finished ones into one
``results.jsonl``, ``runs.csv``, ``summary.csv`` and report, saying which runs (of which
shard) are still missing; merging again gives the same files. A plain ``slamq run CONFIG``
merges too: it finds the shards' runs finished, runs what is missing and scores all.

While a shard runs, ``<output>/shards/I-of-N.running`` is touched every few seconds; a
plain run refuses to start while one is fresh (it would run the same runs twice).
"""

from __future__ import annotations

import json
import os
import re
import socket
import threading
import time
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from slamq.errors import ParamError, SlamqError
from slamq.runner import runner
from slamq.runner.config import RunConfig, load_config
from slamq.runner.execution import write_atomic

__all__ = ["parse_shard", "shard_indices", "run_shard", "merge", "check_no_live_shard",
           "shard_states", "recorded_shard_count"]

#: Seconds between two touches of a running shard's marker; stale after 6 of them.
HEARTBEAT = 5.0


def parse_shard(text: str, env: Mapping[str, str] | None = None,
                known: int | None = None) -> tuple[int, int]:
    """``"I/N"``, ``"N"`` or ``"auto"`` (I, and for auto N, from the array job's
    environment) -> ``(I, N)``, 0 <= I < N.

    In a Kubernetes Indexed Job I is ``JOB_COMPLETION_INDEX``. In a Slurm array whose task
    ids are evenly spaced and as many as the shards (``--array=0-3``, ``1-4``, ``0-6:2``),
    I is the task's position, ``(ID - MIN) / STEP``. Any other array (one task,
    ``--array=2``, or a list, ``--array=1,3``: shards run again) takes its task ids as the
    shard indices. ``auto`` takes N from a regular array's task count, else from
    ``known`` (the shard count an earlier submission recorded in the output folder).

    Examples
    --------
    >>> parse_shard("2/4")
    (2, 4)
    >>> parse_shard("4", {"SLURM_ARRAY_TASK_ID": "3", "SLURM_ARRAY_TASK_MIN": "1",
    ...                   "SLURM_ARRAY_TASK_MAX": "4", "SLURM_ARRAY_TASK_COUNT": "4"})
    (2, 4)
    >>> parse_shard("auto", {"SLURM_ARRAY_TASK_ID": "4", "SLURM_ARRAY_TASK_MIN": "0",
    ...                      "SLURM_ARRAY_TASK_MAX": "4", "SLURM_ARRAY_TASK_STEP": "2",
    ...                      "SLURM_ARRAY_TASK_COUNT": "3"})
    (2, 3)
    >>> parse_shard("4", {"SLURM_ARRAY_TASK_ID": "2", "SLURM_ARRAY_TASK_MIN": "2",
    ...                   "SLURM_ARRAY_TASK_MAX": "2", "SLURM_ARRAY_TASK_COUNT": "1"})
    (2, 4)
    >>> parse_shard("4", {"JOB_COMPLETION_INDEX": "0"})
    (0, 4)
    >>> parse_shard("4/4")
    Traceback (most recent call last):
    slamq.errors.ParamError: --shard 4/4: I must be in 0..3 (I/N, 0-based)
    """
    env = os.environ if env is None else env
    m = re.fullmatch(r"\s*(?:(?:(\d+)\s*/\s*)?(\d+)|(auto))\s*", text)
    if not m or (m.group(2) is not None and int(m.group(2)) < 1):
        raise ParamError(f"--shard {text}: expected I/N (0 <= I < N), N or auto")
    n = None if m.group(3) else int(m.group(2))
    if m.group(1) is not None:
        i = int(m.group(1))
    elif env.get("JOB_COMPLETION_INDEX", "").strip():
        i = int(env["JOB_COMPLETION_INDEX"])
        if n is None:
            raise ParamError("--shard auto: a Kubernetes Indexed Job gives no shard count; "
                             "pass --shard N (the job's completions)")
    elif env.get("SLURM_ARRAY_TASK_ID", "").strip():
        i, n = _slurm_shard(text, env, n, known)
    else:
        raise ParamError(f"--shard {text}: no shard index (give I/N, or run in a Slurm array "
                         "or a Kubernetes Indexed Job)")
    assert n is not None
    if not 0 <= i < n:
        raise ParamError(f"--shard {text}: I must be in 0..{n - 1} (I/N, 0-based)")
    return i, n


def _slurm_shard(text: str, env: Mapping[str, str], n: int | None,
                 known: int | None) -> tuple[int, int]:
    def num(name: str, default: int) -> int:
        value = env.get(name, "").strip()
        try:
            return int(value) if value else default
        except ValueError:
            raise ParamError(f"--shard {text}: {name}={value!r} is not a number") from None

    task = num("SLURM_ARRAY_TASK_ID", 0)
    low = num("SLURM_ARRAY_TASK_MIN", 0)
    count = num("SLURM_ARRAY_TASK_COUNT", 0)
    step = max(num("SLURM_ARRAY_TASK_STEP", 1), 1)
    high = num("SLURM_ARRAY_TASK_MAX", low + step * (count - 1) if count else task)
    regular = count > 1 and (high - low) == step * (count - 1)
    if regular and (n is None or n == count):
        return (task - low) // step, count
    # one task, or a list of tasks: the task ids are the shard indices
    n = n if n is not None else known
    if n is None:
        raise ParamError(
            f"--shard {text}: task {task} of a {'one-task' if count == 1 else 'listed'} array "
            "does not say how many shards the plan has, and the output folder records none; "
            f"run it as: sbatch --array={task} slurm-array.sh CONFIG N (N: the shard count "
            "of the first submission)")
    return task, n


def shard_indices(planned: int, i: int, n: int) -> list[int]:
    """The plan positions of shard ``i`` of ``n``: round-robin.

    Examples
    --------
    >>> shard_indices(10, 1, 4)
    [1, 5, 9]
    """
    return list(range(i, planned, n))


def _marker(config: RunConfig, i: int, n: int) -> Path:
    return config.output / "shards" / f"{i}-of-{n}.running"


def _owner() -> str:
    return f"{socket.gethostname()} {os.getpid()}"


def _live(marker: Path) -> tuple[bool, str, float]:
    """``(alive, "host pid", age in seconds)`` of a shard's marker: alive while it is touched
    (younger than 6 heartbeats), unless its process is known to be gone (same host, no such
    process: a copy killed without cleaning up, e.g. a Slurm requeue's SIGKILL)."""
    try:
        age = time.time() - marker.stat().st_mtime
        who = marker.read_text().strip()
    except OSError:
        return False, "", 0.0
    if age >= 6 * HEARTBEAT:
        return False, who, age
    host, _, pid = who.partition(" ")
    if host == socket.gethostname() and pid.isdigit():
        try:
            os.kill(int(pid), 0)
        except ProcessLookupError:
            return False, who, age
        except OSError:
            pass
    return True, who, age


def _claim(path: Path) -> None:
    """Create ``path`` holding this process's ``host pid``, or refuse while another copy of
    the shard is alive. Creation is exclusive, so of two copies started together one wins;
    a dead copy's marker is moved aside (by one claimer only) and claimed again."""
    path.parent.mkdir(parents=True, exist_ok=True)
    for _ in range(5):
        try:
            fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
        except FileExistsError:
            alive, who, age = _live(path)
            if alive:
                shard = path.name[:-len(".running")].replace("-of-", "/")
                raise SlamqError(
                    f"{path}: shard {shard} is already running ({who}, seen {age:.0f} s ago); "
                    "not starting a second copy (it would run the same runs twice)") from None
            try:
                os.replace(path, path.with_name(f"{path.name}.stale-{os.getpid()}"))
                path.with_name(f"{path.name}.stale-{os.getpid()}").unlink()
            except FileNotFoundError:
                pass  # another claimer moved it first
            continue
        with os.fdopen(fd, "w") as fh:
            fh.write(_owner() + "\n")
        return
    raise SlamqError(f"{path}: could not claim the shard's marker")


@contextmanager
def _heartbeat(path: Path) -> Iterator[None]:
    _claim(path)
    stop = threading.Event()

    def beat() -> None:
        while not stop.wait(HEARTBEAT):
            try:
                os.utime(path)
            except OSError:
                return

    t = threading.Thread(target=beat, name="slamq-shard-heartbeat", daemon=True)
    t.start()
    try:
        yield
    finally:
        stop.set()
        t.join()
        try:  # only our own marker: a copy that took over a stale one keeps its own
            if path.read_text().strip() == _owner():
                path.unlink()
        except OSError:
            pass


def check_no_live_shard(config: RunConfig) -> None:
    """Raise when a shard of this output folder is running now (its marker is fresh).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from slamq.runner import load_config
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> check_no_live_shard(load_config({"base_dir": str(d), "sequences": {"s": "x"},
    ...                                  "algorithms": {"a": {"command": ["true"]}}}))
    """
    folder = config.output / "shards"
    if not folder.is_dir():
        return
    for m in sorted(folder.glob("*.running")):
        alive, who, age = _live(m)
        if alive:
            raise SlamqError(
                f"{m}: shard {m.name[:-len('.running')].replace('-of-', '/')} is running "
                f"({who}, seen {age:.0f} s ago); wait for it, or merge what finished with "
                "slamq run CONFIG --merge")


def run_shard(config: Any, shard: tuple[int, int], *, retry_failed: bool = False,
              progress: Any = None) -> dict[str, Any]:
    """Run shard ``(I, N)`` of a configuration; nothing is scored (see :func:`merge`).

    Returns
    -------
    dict
        ``rows`` (this shard's runs), ``shard`` ``(I, N)``, ``record`` (the path of
        ``<output>/shards/I-of-N.json``: its run keys and outcomes).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp()); _ = (d / "in.txt").write_text("x")
    >>> cfg = {"base_dir": str(d), "output": "o", "sequences": {"s": "in.txt"},
    ...        "iterations": 3, "algorithms": {"t": {"command": ["true"]}}}
    >>> r = run_shard(cfg, (1, 2))
    >>> [row["iteration"] for row in r["rows"]], r["record"].name
    ([2], '1-of-2.json')
    """
    cfg = load_config(config)
    i, n = shard
    select = shard_indices(len(runner.plan(cfg)), i, n)
    record = cfg.output / "shards" / f"{i}-of-{n}.json"
    with _heartbeat(_marker(cfg, i, n)):
        try:
            rows = runner.execute(cfg, retry_failed=retry_failed, progress=progress,
                                  select=select)
        except BaseException:
            # stopped (Ctrl-C, SIGTERM of scancel or a time limit): the merge says so
            write_atomic(record, json.dumps({
                "shard": [i, n], "host": socket.gethostname(), "finished": time.time(),
                "interrupted": True, "runs": []}, indent=1))
            raise
    write_atomic(record, json.dumps({
        "shard": [i, n], "host": socket.gethostname(), "finished": time.time(),
        "interrupted": False,
        "runs": [{"key": r["key"], "folder": r["folder"], "outcome": r["outcome"],
                  "skipped": bool(r.get("skipped"))} for r in rows]}, indent=1))
    return {"rows": rows, "shard": (i, n), "record": record}


def shard_states(config: Any, n: int) -> dict[int, str]:
    """What each shard of ``n`` is doing, as the output folder tells: ``running (host
    pid)``, ``interrupted`` (stopped before its end: scancel, a time limit, Ctrl-C),
    ``finished`` (its record is written) or ``missing`` (never started, or killed without
    a word).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp()); _ = (d / "in.txt").write_text("x")
    >>> cfg = {"base_dir": str(d), "output": "o", "sequences": {"s": "in.txt"},
    ...        "iterations": 2, "algorithms": {"t": {"command": ["true"]}}}
    >>> _ = run_shard(cfg, (0, 2))
    >>> shard_states(cfg, 2)
    {0: 'finished', 1: 'missing'}
    """
    cfg = load_config(config)
    states = {}
    for i in range(n):
        alive, who, _ = _live(_marker(cfg, i, n))
        if alive:
            states[i] = f"running ({who})"
            continue
        try:
            rec = json.loads((cfg.output / "shards" / f"{i}-of-{n}.json").read_text())
        except (OSError, ValueError):
            states[i] = "missing"
            continue
        states[i] = "interrupted" if rec.get("interrupted") else "finished"
    return states


def merge(config: Any) -> dict[str, Any]:
    """Score every finished run of a configuration (the shards' runs) into one results
    file, ``runs.csv``, ``summary.csv`` and report; runs nothing.

    Returns
    -------
    dict
        What :func:`slamq.runner.runner.run` returns (``rows`` are the finished runs), plus
        ``missing``: ``(shard, run folder)`` of every planned run without a ``run.json``
        (the shard as ``"I/N"`` when a shard record names its N, else ``None``).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp()); _ = (d / "in.txt").write_text("x")
    >>> cfg = {"base_dir": str(d), "output": "o", "sequences": {"s": "in.txt"},
    ...        "report": False, "iterations": 2, "algorithms": {"t": {"command": ["true"]}}}
    >>> _ = run_shard(cfg, (0, 2))
    >>> m = merge(cfg)
    >>> len(m["rows"]), [(s, pathlib.Path(f).name) for s, f in m["missing"]]
    (1, [('1/2', '2')])
    """
    cfg = load_config(config)
    planned = runner.execute(cfg, dry_run=True)
    done = [r for r in planned if r.get("outcome") != "planned"]
    n = _shard_count(cfg)
    missing = [(f"{p % n}/{n}" if n else None, r["folder"])
               for p, r in enumerate(planned) if r.get("outcome") == "planned"]
    cfg.output.mkdir(parents=True, exist_ok=True)
    rows = [{k: v for k, v in r.items() if k != "skipped"} for r in done]
    scored = runner.score(cfg, rows) if rows else {
        "results": None, "records": 0, "summary": None, "gifs": [], "report": None}
    return {"rows": rows, **scored, "missing": missing}


def recorded_shard_count(config: Any) -> int | None:
    """The shard count N of the shard records and markers in the output folder (``None``
    when there are none, or several N).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp()); _ = (d / "in.txt").write_text("x")
    >>> cfg = {"base_dir": str(d), "output": "o", "sequences": {"s": "in.txt"},
    ...        "algorithms": {"t": {"command": ["true"]}}}
    >>> recorded_shard_count(cfg) is None
    True
    >>> _ = run_shard(cfg, (0, 3)); recorded_shard_count(cfg)
    3
    """
    return _shard_count(load_config(config))


def _shard_count(config: RunConfig) -> int | None:
    counts = set()
    for p in (config.output / "shards").glob("*-of-*"):
        m = re.fullmatch(r"\d+-of-(\d+)\.(?:json|running)", p.name)
        if m:
            counts.add(int(m.group(1)))
    return counts.pop() if len(counts) == 1 else None
