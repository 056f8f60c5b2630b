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

__all__ = ["parse_shard", "shard_indices", "run_shard", "merge", "check_no_live_shard"]

#: Seconds between two touches of a running shard's marker; stale after 6 of them.
HEARTBEAT = 5.0


def parse_shard(text: str, env: Mapping[str, str] | None = None) -> tuple[int, int]:
    """``"I/N"`` or ``"N"`` (I from the array job's environment) -> ``(I, N)``, 0 <= I < N.

    Examples
    --------
    >>> parse_shard("2/4")
    (2, 4)
    >>> parse_shard("4", {"SLURM_ARRAY_TASK_ID": "3", "SLURM_ARRAY_TASK_MIN": "1"})
    (2, 4)
    >>> parse_shard("4", {"JOB_COMPLETION_INDEX": "0"})
    (0, 4)
    >>> parse_shard("4/4")
    Traceback (most recent call last):
    slamq.errors.ParamError: --shard 4/4: I must be in 0..3 (I/N, 0-based)
    """
    env = os.environ if env is None else env
    m = re.fullmatch(r"\s*(?:(\d+)\s*/\s*)?(\d+)\s*", text)
    if not m or int(m.group(2)) < 1:
        raise ParamError(f"--shard {text}: expected I/N (0 <= I < N) or N")
    n = int(m.group(2))
    if m.group(1) is not None:
        i = int(m.group(1))
    elif env.get("JOB_COMPLETION_INDEX", "").strip():
        i = int(env["JOB_COMPLETION_INDEX"])
    elif env.get("SLURM_ARRAY_TASK_ID", "").strip():
        i = int(env["SLURM_ARRAY_TASK_ID"]) - int(env.get("SLURM_ARRAY_TASK_MIN") or 0)
    else:
        raise ParamError(f"--shard {text}: no shard index (give I/N, or run in a Slurm array "
                         "or a Kubernetes Indexed Job)")
    if not 0 <= i < n:
        raise ParamError(f"--shard {text}: I must be in 0..{n - 1} (I/N, 0-based)")
    return i, n


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


@contextmanager
def _heartbeat(path: Path) -> Iterator[None]:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(f"{socket.gethostname()} {os.getpid()}\n")
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
        path.unlink(missing_ok=True)


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
    now = time.time()
    for m in sorted(folder.glob("*.running")):
        try:
            age = now - m.stat().st_mtime
            who = m.read_text().strip()
        except OSError:
            continue
        if age < 6 * HEARTBEAT:
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
    with _heartbeat(_marker(cfg, i, n)):
        rows = runner.execute(cfg, retry_failed=retry_failed, progress=progress, select=select)
    record = cfg.output / "shards" / f"{i}-of-{n}.json"
    write_atomic(record, json.dumps({
        "shard": [i, n], "host": socket.gethostname(), "finished": time.time(),
        "runs": [{"key": r["key"], "folder": r["folder"], "outcome": r["outcome"]}
                 for r in rows]}, indent=1))
    return {"rows": rows, "shard": (i, n), "record": record}


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


def _shard_count(config: RunConfig) -> int | None:
    counts = set()
    for p in (config.output / "shards").glob("*-of-*.json"):
        m = re.fullmatch(r"\d+-of-(\d+)\.json", p.name)
        if m:
            counts.add(int(m.group(1)))
    return counts.pop() if len(counts) == 1 else None
