"""``slamq run --scheduler``: each planned run is a task on a Dask worker.

The client (``slamq run CONFIG --scheduler tcp://host:8786``, or ``--scheduler dask`` for a
local cluster of ``parallel`` worker processes) plans the runs and skips the finished ones
exactly as a local run does; every other run becomes one Dask task. On the worker the task
runs the same code as a local run (:func:`slamq.runner.execution.execute_one`: its own
session, timeout, SIGINT/SIGTERM/SIGKILL, outcome, collected map and trajectory).

Slots
    Each task asks for one unit of the worker resource ``slamq_run``. A worker started
    with ``--resources slamq_run=N`` runs N SLAM programs at once; a worker that declares
    nothing is given ``slamq_run=1`` when the client connects (one run per worker process:
    a playback-driven run needs its own cores). A run's ``{slot}`` (and its ROS domain id)
    is a number free on the whole host (a lock file per slot), so worker processes sharing
    a host never share a ROS domain.

Outputs (``outputs=``, ``--outputs``)
    ``auto`` (the default): a worker that sees the client's output folder (a probe file
    the client writes there) writes the run straight into it, as a local run would, and
    writes ``run.json`` itself, so a finished run is recorded even if the client dies;
    a worker that does not see it runs in a scratch folder and returns the run folder as
    bytes (a tar), which the client unpacks into the output folder before writing
    ``run.json``. ``shared`` requires the shared folder (a worker without it records an
    ``infrastructure`` failure); ``return`` always sends the bytes. Auto is the default
    because it is right on both kinds of cluster without a setting, and takes the cheaper
    path whenever it can. Inputs (``sequences.*.input``, config templates) must exist at
    the same paths on the workers in every mode.

Faults
    A worker that dies mid-run (killed, its machine gone) loses its task to the scheduler,
    which runs it again on another worker (Dask's ``allowed_failures``); the dead worker's
    SLAM processes are stopped by a small guard process each worker process starts, which
    kills the process groups of the runs in flight when its pipe from the worker closes.
    A run is recorded once: each attempt runs in its own folder (``.ITERATION.attempt-ID``
    beside the run folder, or a scratch folder) and only a finished attempt becomes the
    run folder, with its ``run.json``; an attempt that finishes after another (its worker
    was cut off, not dead) is dropped. When the
    scheduler goes away the client raises :class:`SchedulerGone` (exit 2) naming how
    many runs finished, where they are listed and how to resume. Ctrl-C of the client
    cancels the tasks; each running task sees its cancellation and stops its groups
    (SIGINT, SIGTERM, SIGKILL), and the client waits for that before it exits.

The client connects with a timeout of ``SLAMQ_DASK_TIMEOUT`` seconds (default 20). The
workers need slamq (the same version) and the SLAM programs installed.
"""

from __future__ import annotations

import dataclasses
import fcntl
import io
import json
import os
import shutil
import socket
import subprocess
import sys
import tarfile
import tempfile
import threading
import time
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Callable

from slamq.errors import ParamError, SlamqError
from slamq.runner import execution, process
from slamq.runner.config import RunConfig
from slamq.runner.planning import RunSpec

__all__ = ["RESOURCE", "OUTPUTS", "SchedulerGone", "dask_backend", "execute_dask", "run_task",
           "running_here"]

#: The Dask worker resource one run takes.
RESOURCE = "slamq_run"
#: Where run folders go: ``auto``, ``shared`` (the output folder), ``return`` (as bytes).
OUTPUTS = ("auto", "shared", "return")
_PROBE = ".slamq-probe"


class SchedulerGone(SlamqError):
    """The Dask scheduler went away while runs were in flight."""


# ------------------------------------------------------------------------------------------
# worker side

#: The guard: reads "+FOLDER" / "-FOLDER" lines; at EOF (its worker ended, however) it stops
#: the process groups listed in the ``groups.txt`` of the folders still registered.
_GUARD = r"""
import os, signal, sys, time
folders = set()
for line in sys.stdin:
    path = line[1:].rstrip("\n")
    if line.startswith("+"):
        folders.add(path)
    else:
        folders.discard(path)
groups = set()
for f in folders:
    try:
        groups.update(int(x) for x in open(os.path.join(f, "groups.txt")).read().split())
    except (OSError, ValueError):
        pass
for sig, wait in ((signal.SIGINT, 1.0), (signal.SIGTERM, 2.0), (signal.SIGKILL, 1.0)):
    for g in list(groups):
        try:
            os.killpg(g, sig)
        except OSError:
            groups.discard(g)
    end = time.monotonic() + wait
    while groups and time.monotonic() < end:
        time.sleep(0.05)
        for g in list(groups):
            try:
                os.killpg(g, 0)
            except OSError:
                groups.discard(g)
    if not groups:
        break
"""

_guard_lock = threading.Lock()
_guard: subprocess.Popen | None = None
_running: set[str] = set()


def _tell_guard(line: str) -> None:
    global _guard
    with _guard_lock:
        if _guard is None or _guard.poll() is not None:
            _guard = subprocess.Popen(
                [sys.executable, "-c", _GUARD], stdin=subprocess.PIPE, stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL, start_new_session=True, text=True)
        assert _guard.stdin is not None
        _guard.stdin.write(line + "\n")
        _guard.stdin.flush()


@contextmanager
def _guarded(folder: Path) -> Iterator[None]:
    _tell_guard(f"+{folder}")
    _running.add(str(folder))
    try:
        yield
    finally:
        _running.discard(str(folder))
        _tell_guard(f"-{folder}")


def running_here() -> list[str]:
    """The run folders this worker process is running now (for the client's Ctrl-C wait).

    Examples
    --------
    >>> running_here()
    []
    """
    return sorted(_running)


@contextmanager
def _host_slot() -> Iterator[int]:
    """The lowest slot number no other run on this host holds (a lock file per slot)."""
    base = Path(tempfile.gettempdir()) / f"slamq-slots-{os.getuid()}"
    base.mkdir(parents=True, exist_ok=True)
    for n in range(4096):
        fh = open(base / f"{n}.lock", "w")
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            fh.close()
            continue
        try:
            yield n
        finally:
            fh.close()
        return
    raise SlamqError(f"{base}: no free run slot among 4096")


def _watch_cancel(stop: threading.Event, done: threading.Event) -> None:
    """Set ``stop`` when the client cancels this task (or forgets it)."""
    try:
        from distributed import get_worker

        worker = get_worker()
        key = worker.get_current_task()
    except (ImportError, ValueError):
        return

    def loop() -> None:
        while not done.wait(0.1):
            ts = worker.state.tasks.get(key)
            if ts is None or ts.state in ("cancelled", "released", "forgotten"):
                stop.set()
                return

    threading.Thread(target=loop, name="slamq-run-cancel", daemon=True).start()


def _sees(probe: tuple[str, str]) -> bool:
    try:
        return Path(probe[0]).read_text() == probe[1]
    except OSError:
        return False


def _moved(row: dict[str, Any], src: Path, dest: Path) -> dict[str, Any]:
    out = dict(row)
    for k in ("map", "trajectory"):
        if isinstance(out.get(k), str) and out[k].startswith(str(src)):
            out[k] = str(dest) + out[k][len(str(src)):]
    return out


def run_task(spec: RunSpec, key: str, command: Any, config: RunConfig,
             probe: tuple[str, str], outputs: str = "auto") -> dict[str, Any]:
    """Run one planned run on this machine (what a Dask task calls).

    Returns ``{"row": ROW}`` (the run's ``run.json`` record; written in place when the
    output folder is shared), plus ``"tar"`` (the run folder's bytes) when it is not, or
    ``{"row": None}`` when the run was cancelled before it ended.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from slamq.runner import load_config, runner
    >>> d = pathlib.Path(tempfile.mkdtemp()); _ = (d / "in.txt").write_text("x")
    >>> cfg = load_config({"base_dir": str(d), "output": "o", "sequences": {"s": "in.txt"},
    ...                    "algorithms": {"t": {"command": ["true"]}}})
    >>> spec = runner.plan(cfg)[0]; key, pieces = runner.run_key(spec, cfg)
    >>> r = run_task(spec, key, pieces["command"], cfg, ("/nonexistent", "x"), "return")
    >>> r["row"]["outcome"], r["row"]["folder"] == str(spec.folder), len(r["tar"]) > 0
    ('ok', True, True)
    """
    shared = _sees(probe)
    if outputs == "shared" and not shared:
        row = execution.run_row(spec, key, {"outcome": "infrastructure", "reason": (
            f"{socket.gethostname()} does not see the output folder {config.output} "
            "(outputs: shared)")}, 1)
        return {"row": {**row, "command": command, "host": socket.gethostname()}}
    here = shared and outputs != "return"
    # each attempt in its own folder: an attempt the scheduler gave up on (its worker cut
    # off, not dead) never writes into the run folder another attempt fills
    attempt = f"attempt-{uuid.uuid4().hex[:10]}"
    folder = (spec.folder.parent / f".{spec.folder.name}.{attempt}" if here else
              Path(tempfile.gettempdir()) / f"slamq-runs-{os.getuid()}" / f"{key}.{attempt}")
    local = dataclasses.replace(spec, folder=folder)
    stop, done = threading.Event(), threading.Event()
    _watch_cancel(stop, done)
    try:
        with _host_slot() as slot, _guarded(folder):
            attempts = 0
            while True:
                attempts += 1
                result = execution.execute_one(local, key, slot, config, stop)
                if result is None:
                    shutil.rmtree(folder, ignore_errors=True)
                    return {"row": None}
                if result["outcome"] != "infrastructure" or attempts > config.retries:
                    break
    finally:
        done.set()
    row = _moved(execution.run_row(spec, key, result, attempts), folder, spec.folder)
    row.update(command=command, host=socket.gethostname())
    if here:
        execution.write_atomic(folder / "run.json", json.dumps(row, indent=1, default=str))
        return {"row": _settle(folder, spec.folder)}
    buf = io.BytesIO()
    with tarfile.open(fileobj=buf, mode="w") as tar:
        tar.add(folder, arcname=".")
    shutil.rmtree(folder, ignore_errors=True)
    return {"row": row, "tar": buf.getvalue()}


def _settle(attempt: Path, final: Path) -> dict[str, Any]:
    """Move a finished attempt (``run.json`` written) into the run folder, unless another
    attempt finished first: the first one stays, this one is dropped. The run's record."""
    done = final / "run.json"
    if done.is_file():
        try:
            kept = json.loads(done.read_text())
            shutil.rmtree(attempt, ignore_errors=True)
            return kept
        except (OSError, ValueError):
            pass
    if final.exists():
        shutil.rmtree(final)
    os.rename(attempt, final)
    return json.loads(done.read_text())


def _slots_plugin() -> Any:
    """A Dask worker plugin: one ``slamq_run`` slot for a worker that declares none."""
    from distributed.diagnostics.plugin import WorkerPlugin

    class SlamqRunSlots(WorkerPlugin):
        idempotent = True
        name = "slamq-run-slots"

        def setup(self, worker: Any) -> None:
            if RESOURCE not in (worker.state.total_resources or {}):
                worker.loop.add_callback(worker.set_resources, **{RESOURCE: 1})

    return SlamqRunSlots()


def _unstick() -> Callable[[Any], int]:
    """A function for ``client.run_on_scheduler``: send the tasks waiting in ``no-worker``
    to a worker that can now run them; returns how many.

    A worker that declares no ``slamq_run`` slot gets one from :func:`_slots_plugin` only
    after it has joined, and the scheduler looks at its ``no-worker`` tasks again when a
    worker joins, not when a worker's resources change (``Scheduler.add_resources``): a
    task submitted before the slot was known would wait forever. This does what joining
    does (``bulk_schedule_unrunnable_after_adding_worker``) for every worker with a slot.
    It is defined in a function so that cloudpickle ships it by value: the scheduler need
    not have slamq installed.
    """
    name = RESOURCE

    def unstick(dask_scheduler: Any) -> int:
        recs: dict[Any, str] = {}
        for ws in list(dask_scheduler.workers.values()):
            if name in (ws.resources or {}):
                recs.update(dask_scheduler.bulk_schedule_unrunnable_after_adding_worker(ws))
        if recs:
            dask_scheduler.transitions(recs, stimulus_id=f"slamq-unstick-{time.time()}")
        return len(recs)

    return unstick


def _keep_unstuck(client: Any, stop: threading.Event, every: float = 1.0) -> None:
    """Run :func:`_unstick` on the scheduler every ``every`` seconds until ``stop`` is set
    (a thread beside the loop that collects results). A scheduler without the internals it
    uses, or gone, ends the thread: the loop reports a scheduler that went away."""
    fn = _unstick()
    while not stop.wait(every):
        try:
            client.run_on_scheduler(fn)
        except Exception:  # noqa: BLE001 - other dask versions, or the scheduler is gone
            return


# ------------------------------------------------------------------------------------------
# client side

def _unpack(tar: bytes, folder: Path) -> None:
    if folder.exists():
        shutil.rmtree(folder)
    folder.mkdir(parents=True)
    with tarfile.open(fileobj=io.BytesIO(tar)) as t:
        if hasattr(tarfile, "data_filter"):
            t.extractall(folder, filter="data")
        else:  # pragma: no cover - Python < 3.11.4
            t.extractall(folder)


def _connect(scheduler: Any, config: RunConfig) -> tuple[Any, Any]:
    try:
        from distributed import Client, LocalCluster
    except ImportError as exc:
        raise ParamError("slamq run --scheduler needs dask.distributed: "
                         "pip install 'slamq[dask]'") from exc
    if not isinstance(scheduler, str):
        return scheduler, None
    address = scheduler
    if scheduler == "dask":
        address = os.environ.get("DASK_SCHEDULER_ADDRESS") or ""
    if not address:
        cluster = LocalCluster(n_workers=config.parallel, threads_per_worker=1, processes=True,
                               dashboard_address=None, resources={RESOURCE: 1})
        return Client(cluster), cluster
    timeout = float(os.environ.get("SLAMQ_DASK_TIMEOUT", "20"))
    try:
        return Client(address, timeout=timeout), None
    except (OSError, TimeoutError) as exc:
        raise ParamError(f"cannot reach the Dask scheduler at {address}: {exc}") from exc


def _wait_stopped(client: Any, seconds: float) -> None:
    """After a cancel: wait until no worker runs a run of ours (their groups are stopped)."""
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        try:
            left = client.run(running_here, nanny=False)
        except Exception:  # noqa: BLE001 - a worker or the scheduler going away: stop waiting
            return
        if not any(left.values()):
            return
        time.sleep(0.1)


def execute_dask(config: RunConfig, keyed: list[tuple[RunSpec, str, dict[str, Any]]],
                 rows: list[dict[str, Any] | None], todo: list[int],
                 progress: Callable[[dict[str, Any]], None] | None = None, *,
                 scheduler: Any = "dask", outputs: str = "auto") -> None:
    """Run ``todo`` (indices into ``keyed``) as Dask tasks; fills ``rows`` in place.

    Parameters
    ----------
    config : RunConfig
        The loaded configuration.
    keyed : list of (RunSpec, key, pieces)
        Every planned run with its run key (:func:`slamq.runner.planning.run_key`).
    rows : list
        One slot per planned run: the finished rows are written here.
    todo : list of int
        The runs to run.
    progress : callable, optional
        ``progress(row)`` as each run finishes.
    scheduler : str or distributed.Client
        ``"dask"`` (``DASK_SCHEDULER_ADDRESS``, else a local cluster of ``parallel`` worker
        processes), a scheduler address (``tcp://host:8786``) or a Client.
    outputs : {"auto", "shared", "return"}
        See the module docstring.

    Raises
    ------
    SchedulerGone
        The scheduler went away; the message says what finished and how to resume.
    KeyboardInterrupt
        Ctrl-C: raised again once the workers have stopped the runs in flight.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> from slamq.runner import load_config, runner
    >>> d = pathlib.Path(tempfile.mkdtemp()); _ = (d / "in.txt").write_text("x")
    >>> cfg = load_config({"base_dir": str(d), "output": "o", "sequences": {"s": "in.txt"},
    ...                    "algorithms": {"t": {"command": ["true"]}}})
    >>> execute_dask(cfg, [], [], [], outputs="sideways")
    Traceback (most recent call last):
    slamq.errors.ParamError: outputs must be one of auto, shared, return, got 'sideways'
    """
    if outputs not in OUTPUTS:
        raise ParamError(f"outputs must be one of {', '.join(OUTPUTS)}, got {outputs!r}")
    if not todo:
        return
    from distributed import as_completed

    config.output.mkdir(parents=True, exist_ok=True)
    token = uuid.uuid4().hex
    probe_path = config.output / _PROBE
    probe_path.write_text(token)
    client, cluster = _connect(scheduler, config)
    address = getattr(client.scheduler, "address", scheduler)
    futures: dict[Any, int] = {}
    stop = threading.Event()  # ends the thread that keeps tasks from waiting forever
    try:
        client.register_plugin(_slots_plugin(), name="slamq-run-slots")
        threading.Thread(target=_keep_unstuck, args=(client, stop), daemon=True,
                         name="slamq-dask-unstick").start()
        batch = token[:8]

        def take(fut: Any) -> None:
            """A finished task's row into ``rows`` (and its files, when returned)."""
            i = futures.pop(fut)
            try:
                result = fut.result()
                fut.release()  # the worker may forget the result (a tar can be large)
            except Exception as exc:  # noqa: BLE001 - a lost task is said below
                if _gone(client):
                    raise _gone_error(config, keyed, rows, todo, address) from exc
                spec, key, pieces = keyed[i]
                row = execution.run_row(spec, key, {"outcome": "infrastructure",
                                                   "reason": f"dask: {exc!r}"[:500]}, 1)
                row["command"] = pieces["command"]  # no run.json: a resume runs it
                result = {"row": row}
            row = result.get("row")
            if row is None:
                return
            if "tar" in result:
                _unpack(result["tar"], keyed[i][0].folder)
                execution.write_atomic(keyed[i][0].folder / "run.json",
                                       json.dumps(row, indent=1, default=str))
            rows[i] = row
            if progress is not None:
                progress(row)

        # a Ctrl-C (or SIGTERM) is noted and seen here, between tasks, instead of raising
        # wherever the main thread is (process.interrupts_caught): the stopping below then
        # always runs whole
        with process.interrupts_caught() as interrupted:
            try:
                for i in todo:
                    if interrupted.is_set():
                        break
                    spec, key, pieces = keyed[i]
                    futures[client.submit(
                        run_task, spec, key, pieces["command"], config,
                        (str(probe_path), token), outputs, resources={RESOURCE: 1},
                        pure=False, key=f"slamq-run-{batch}-{i}-{key[:12]}")] = i
                finished = as_completed(list(futures))
                while not (interrupted.is_set() or finished.is_empty()):
                    ready = finished.next_batch(block=False)
                    if not ready:
                        time.sleep(0.05)
                    for fut in ready:
                        take(fut)
                if not interrupted.is_set():
                    for i in todo:  # what attempts on dead workers left beside finished runs
                        folder = keyed[i][0].folder
                        if (folder / "run.json").is_file():
                            for stale in folder.parent.glob(f".{folder.name}.attempt-*"):
                                shutil.rmtree(stale, ignore_errors=True)
            except (OSError, TimeoutError) as exc:
                raise _gone_error(config, keyed, rows, todo, address) from exc
            if interrupted.is_set():
                client.cancel(list(futures), force=True)
                _wait_stopped(client, sum(config.grace) + 10)
        if interrupted.is_set():
            raise KeyboardInterrupt
    finally:
        stop.set()
        probe_path.unlink(missing_ok=True)
        try:
            client.close(timeout=5)
        except Exception:  # noqa: BLE001 - closing a client whose scheduler is gone
            pass
        if cluster is not None:
            cluster.close()


def dask_backend(scheduler: Any = "dask", outputs: str = "auto") -> Callable[..., None]:
    """A ``backend`` for :func:`slamq.runner.runner.run` / ``execute`` that runs on Dask.

    Examples
    --------
    >>> from slamq.runner import runner
    >>> callable(dask_backend("tcp://127.0.0.1:8786", outputs="return"))
    True
    """
    if outputs not in OUTPUTS:
        raise ParamError(f"outputs must be one of {', '.join(OUTPUTS)}, got {outputs!r}")

    def backend(config: RunConfig, keyed: list, rows: list, todo: list[int],
                progress: Any = None) -> None:
        execute_dask(config, keyed, rows, todo, progress, scheduler=scheduler, outputs=outputs)

    return backend


def _gone(client: Any) -> bool:
    return client.status not in ("running", "connecting", "newly-created") or \
        getattr(client.scheduler_comm, "comm", None) is None


def _gone_error(config: RunConfig, keyed: list, rows: list, todo: list[int],
                address: Any) -> SchedulerGone:
    import logging

    for name in ("distributed.client", "distributed.comm", "distributed.core"):
        logging.getLogger(name).setLevel(logging.CRITICAL)  # the reconnect's tracebacks
    finished = [keyed[i][0] for i in todo if rows[i] is not None
                or (keyed[i][0].folder / "run.json").is_file()]
    listing = config.output / "runs-finished.txt"
    listing.write_text("".join(f"{s.folder}\n" for s in finished))
    where = config.source if config.source != "<dict>" else "CONFIG"
    return SchedulerGone(
        f"the Dask scheduler at {address} went away: {len(finished)} of {len(todo)} runs of "
        f"this call finished (listed in {listing}); a run still going on a worker is "
        f"recorded if it ends. Resume with: slamq run {where} --scheduler ADDRESS "
        f"(finished runs are skipped), or without --scheduler to finish here")
