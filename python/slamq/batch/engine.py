"""``evaluate_many``: many maps in parallel, streamed in order, resumable, local or on Dask.

How it runs
-----------
* **Local** (default): a thread pool of ``threads`` workers. Each worker hashes, loads
  (OpenCV decoding releases the GIL) and evaluates one map with ``slamq.evaluate`` (the
  Rust core releases the GIL), so the threads run in parallel; each map is evaluated on
  one core (``threads=1``: every calling thread has its own 1-thread pool). At most
  ``max(2 * threads, chunk_size)`` maps are queued at once and only the running ones are
  in memory; records come back in input order.
* **concurrent.futures.Executor**: the same, with your executor (a process pool works).
* **Dask**: chunks of ``chunk_size`` runs are sent to the workers (only paths travel; the
  workers must see the same files), each chunk is evaluated with a thread pool inside the
  worker, and results stream back with ``as_completed``; at most two chunks per worker
  thread are in flight, and records are put back in input order before they are written.

Results are written to ``out`` one chunk at a time (see :mod:`slamq.batch.results`).
"""

from __future__ import annotations

import os
import uuid
import warnings
from collections import deque
from collections.abc import Iterator
from concurrent.futures import Executor, Future, ThreadPoolExecutor
from typing import Any, Callable

from slamq.batch.records import EvalOptions, evaluate_run
from slamq.batch.runs import Run, discover_runs
from slamq.errors import ParamError
from slamq.results.columns import settings_difference
from slamq.results.files import ResultsFile, results_format

__all__ = ["evaluate_many", "evaluate_chunk"]

ProgressFn = Callable[[int, int], None]

DEFAULT_CHUNK_SIZE = 32


def _default_threads() -> int:
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return max(1, os.cpu_count() or 1)


def _positive(name: str, value: Any) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise ParamError(f"{name} must be a positive integer, got {value!r}")
    return value


def evaluate_many(
    sources: Any,
    *,
    threads: int | None = None,
    executor: None | str | Executor | Any = None,
    chunk_size: int | None = None,
    out: None | str | os.PathLike[str] = None,
    progress: ProgressFn | None = None,
    ate_align: str = "se2",
    ate_max_dt: float = 0.01,
    ate_unsorted: str = "error",
    gt_align: str = "icp",
    gt_tolerance: float | None = None,
    gt_max_distance: float | None = None,
    **params: Any,
) -> Iterator[dict[str, Any]]:
    """Evaluate many maps; yield one record per map, in input order.

    Parameters
    ----------
    sources : path, Run, or an iterable of them
        Folders, manifest CSV files, map files or :class:`Run` objects; see
        :func:`slamq.discover_runs`.
    threads : int, optional
        Worker threads (local), or threads per chunk inside each Dask worker. Default: the
        CPUs available (local); the worker's CPUs divided by its Dask threads (Dask).
    executor : None, "local", "dask", a scheduler address, a ``dask.distributed.Client``,
        or a ``concurrent.futures.Executor``
        Where the maps are evaluated. ``"dask"`` connects to ``DASK_SCHEDULER_ADDRESS``
        when set, else starts a local Dask cluster for this call; a string such as
        ``"tcp://host:8786"`` connects to that scheduler.
    chunk_size : int, optional
        Maps per results-file append (and per Dask task). Default 32. A batch killed
        mid-way loses at most the chunks in flight.
    out : path, optional
        Results file (``.parquet`` or ``.jsonl``), appended as chunks finish. Runs already
        in it with no error, the same content hash, parameters and trajectory files are
        skipped (and not yielded); failed runs are retried and their old rows replaced.
        Stored records made with other settings are replaced too, with a ``UserWarning``
        (which also says when records of maps outside this batch keep other settings).
    progress : callable(done, total), optional
        Called with (0, total) first, then after every map (skipped ones included).
    ate_align, ate_max_dt, ate_unsorted
        Trajectory error options (SPEC section 6; ``ate_unsorted`` as ``unsorted`` of
        :func:`slamq.load_trajectory`), used for runs with a trajectory and a
        ground truth. A trajectory that cannot be scored sets ``ate_error``, not ``error``.
    gt_align, gt_tolerance, gt_max_distance
        ``align``, ``tolerance`` (metres) and ``max_distance`` (metres) of
        :func:`slamq.compare` for runs whose sequence has a ground-truth map (``gt_map``,
        see :func:`slamq.discover_runs`): they get the ``gt_*`` columns. A ground truth
        that cannot be compared sets ``gt_error``, not ``error``.
    **params
        Keywords of :func:`slamq.evaluate`: metric parameters, ``unknown_value``,
        ``curve``, ``verify``.

    Yields
    ------
    dict
        The record of one map: ``map, algorithm, sequence, run, trajectory, groundtruth,
        hash, unknown_value, error, seconds``, every ``MapQuality.to_dict()`` key
        (``curve`` only when asked for), ``ate_*`` (None without trajectory) and ``gt_*``
        (None without a ground-truth map).
        A map that cannot be read or evaluated gives a record whose ``error`` is
        ``"file: reason"``; the batch goes on.

    Raises
    ------
    slamq.ParamError
        Bad parameters or executor, before any map is evaluated.
    slamq.MapError
        A source that does not exist or a malformed manifest.

    Examples
    --------
    >>> import pathlib, tempfile, numpy as np, cv2, slamq
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> img = np.full((20, 20), 254, np.uint8); img[5:15, 5:15] = 0
    >>> for name in ("a_map", "b_map"):
    ...     _ = cv2.imwrite(str(d / f"{name}.pgm"), img)
    >>> [(r["algorithm"], r["occupied"]) for r in slamq.evaluate_many(d, threads=2)]
    [('a', 100), ('b', 100)]
    """
    options = EvalOptions(
        params, ate_align=ate_align, ate_max_dt=ate_max_dt, ate_unsorted=ate_unsorted,
        gt_align=gt_align, gt_tolerance=gt_tolerance, gt_max_distance=gt_max_distance,
    )
    if threads is not None:
        _positive("threads", threads)
    chunk = DEFAULT_CHUNK_SIZE if chunk_size is None else _positive("chunk_size", chunk_size)
    if out is not None:
        results_format(out)  # a bad suffix fails now, not after discovery
    runs = discover_runs(sources)
    backend = _backend(executor)
    return _stream(runs, options, backend, threads, chunk, out, progress)


def _backend(executor: Any) -> tuple[str, Any]:
    if executor is None or executor == "local":
        return "local", None
    if isinstance(executor, Executor):
        return "executor", executor
    if isinstance(executor, str):
        if executor == "dask" or "://" in executor or ":" in executor:
            return "dask", executor
        raise ParamError(
            f"executor must be 'local', 'dask', a scheduler address, a Dask Client or a "
            f"concurrent.futures.Executor, got {executor!r}"
        )
    if type(executor).__name__ == "Client" and hasattr(executor, "submit"):
        return "dask", executor
    raise ParamError(f"unsupported executor {executor!r}")


def _stream(
    runs: list[Run],
    options: EvalOptions,
    backend: tuple[str, Any],
    threads: int | None,
    chunk: int,
    out: Any,
    progress: ProgressFn | None,
) -> Iterator[dict[str, Any]]:
    store = ResultsFile(out) if out is not None else None
    done: dict[tuple[str, str, str, str], str] = {}
    if store is not None:
        other = 0  # stored records computed with other settings
        for key, rec in store.done():
            if rec.get("error") in (None, ""):
                done[key] = options.fingerprint(rec)
            other += rec.get("config") not in (None, "", options.config)
        if other:
            _warn_other_settings(store, runs, options, other)
    total = len(runs)
    finished = 0
    if progress is not None:
        progress(0, total)
    kind, target = backend
    if kind == "dask":
        results = _run_dask(runs, options, done, target, threads, chunk)
    else:
        results = _run_local(runs, options, done, target, threads, chunk)
    try:
        buffer: list[dict[str, Any]] = []
        for rec in results:
            finished += 1
            if rec is not None:
                buffer.append(rec)
            if progress is not None:
                progress(finished, total)
            if len(buffer) >= chunk:
                if store is not None:
                    store.append(buffer)
                yield from buffer
                buffer = []
        if buffer:
            if store is not None:
                store.append(buffer)
            yield from buffer
    finally:
        results.close()  # cancel queued maps when the consumer stops early
        if store is not None:
            store.close()


def _warn_other_settings(
    store: ResultsFile, runs: list[Run], options: EvalOptions, other: int
) -> None:
    """Say that a results file holds records made with other settings, and whether the
    file will mix settings once this batch is done (records of maps not in this batch)."""
    keys = {r.key for r in runs}
    configs = [rec.get("config") for _, rec in store.done()] + [options.config]
    stay = sum(
        1 for key, rec in store.done()
        if key not in keys and rec.get("config") not in (None, "", options.config)
    )
    text = (
        f"{store.path}: {other} stored record(s) were computed with other settings "
        f"({settings_difference(configs) or 'unknown'}); this batch evaluates its maps again"
    )
    if stay:
        text += (
            f", but {stay} record(s) of maps outside this batch keep theirs, so the file "
            "will mix settings (use another results file)"
        )
    warnings.warn(text, UserWarning, stacklevel=4)


def _run_local(
    runs: list[Run],
    options: EvalOptions,
    done: dict[tuple[str, str, str, str], str],
    executor: Executor | None,
    threads: int | None,
    chunk: int,
) -> Iterator[dict[str, Any] | None]:
    n = threads or _default_threads()
    if executor is not None:
        n = max(n, getattr(executor, "_max_workers", n))
    own = executor is None
    pool = ThreadPoolExecutor(max_workers=n, thread_name_prefix="slamq") if own else executor
    assert pool is not None
    window = max(2 * n, chunk)
    pending: deque[Future[dict[str, Any] | None]] = deque()
    try:
        for run in runs:
            pending.append(pool.submit(evaluate_run, run, options, done.get(run.key)))
            if len(pending) >= window:
                yield pending.popleft().result()
        while pending:
            yield pending.popleft().result()
    finally:
        for f in pending:
            f.cancel()
        if own:
            pool.shutdown(wait=True, cancel_futures=True)


def evaluate_chunk(
    runs: list[Run], options: EvalOptions, done: list[str | None], threads: int | None
) -> list[dict[str, Any] | None]:
    """Evaluate a chunk of runs with a local thread pool (what a Dask task runs)."""
    if threads is None:
        cpus = _default_threads()
        try:
            from distributed import get_worker

            per_task = max(1, int(get_worker().state.nthreads))
        except (ImportError, ValueError, AttributeError):
            per_task = 1
        threads = max(1, cpus // per_task)
    threads = min(threads, max(1, len(runs)))
    if threads == 1:
        return [evaluate_run(r, options, d) for r, d in zip(runs, done)]
    with ThreadPoolExecutor(max_workers=threads, thread_name_prefix="slamq-chunk") as pool:
        return list(pool.map(evaluate_run, runs, [options] * len(runs), done))


def _run_dask(
    runs: list[Run],
    options: EvalOptions,
    done: dict[tuple[str, str, str, str], str],
    target: Any,
    threads: int | None,
    chunk: int,
) -> Iterator[dict[str, Any] | None]:
    try:
        from distributed import Client, as_completed
    except ImportError as exc:
        raise ParamError(
            "the Dask executor needs dask.distributed: pip install 'slamq[dask]'"
        ) from exc
    own_client = False
    if isinstance(target, str):
        address = target
        if target == "dask":
            address = os.environ.get("DASK_SCHEDULER_ADDRESS") or None
        try:
            client = Client(address) if address else Client(processes=True)
        except OSError as exc:
            raise ParamError(f"cannot reach the Dask scheduler at {address}: {exc}") from exc
        own_client = True
    else:
        client = target
    try:
        chunks = [runs[i : i + chunk] for i in range(0, len(runs), chunk)]
        batch_id = uuid.uuid4().hex[:12]
        worker_threads = sum(client.nthreads().values()) or 1
        window = max(2, 2 * worker_threads)
        results: dict[int, list[dict[str, Any] | None]] = {}
        futures: dict[Any, int] = {}
        ac = as_completed()
        next_submit = 0
        next_yield = 0

        def submit(i: int) -> None:
            part = chunks[i]
            fut = client.submit(
                evaluate_chunk, part, options, [done.get(r.key) for r in part], threads,
                pure=False, key=f"slamq-batch-{batch_id}-{i}",
            )
            futures[fut] = i
            ac.add(fut)

        while next_submit < len(chunks) and next_submit - next_yield < window:
            submit(next_submit)
            next_submit += 1
        while next_yield < len(chunks):
            fut = next(ac)
            i = futures.pop(fut)
            results[i] = fut.result()
            fut.release()
            while next_yield in results:
                yield from results.pop(next_yield)
                next_yield += 1
                if next_submit < len(chunks) and next_submit - next_yield < window:
                    submit(next_submit)
                    next_submit += 1
    finally:
        if own_client:
            cluster = getattr(client, "cluster", None)
            client.close()
            if cluster is not None and target == "dask" and not os.environ.get(
                "DASK_SCHEDULER_ADDRESS"
            ):
                cluster.close()
