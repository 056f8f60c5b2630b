"""``evaluate_many``: many maps in parallel, streamed in order, resumable, local or on Dask.

How it runs
-----------
* **Local** (default): a thread pool of ``threads`` workers. Each worker hashes, loads
  (file reads, hashing and the map_saver pass release the GIL) and evaluates one map with
  ``slamq.evaluate`` (the Rust core releases the GIL), so the threads run in parallel;
  each map is evaluated on one core, the worker's own: the workers are adopted by the
  core (:func:`slamq._core.adopt_thread`) instead of handing each map to a second thread
  and waiting for it. The workers are kept between batches (one set per thread count,
  for the last four counts used; made again after a fork), since the core keeps about 8 KB
  for every thread it adopted.
  At most ``max(2 * threads, chunk_size) + chunk_size // 2 - 1`` maps are queued at once
  and only the running ones are in memory; finished maps are collected half a chunk at a
  time (or what finished within 50 ms); records come back in input order.
* **concurrent.futures.Executor**: the same, with your executor (a process pool works).
* **Dask**: chunks of ``chunk_size`` runs are sent to the workers (only paths travel; the
  workers must see the same files), each chunk is evaluated with a thread pool inside the
  worker, and results stream back with ``as_completed``; at most two chunks per worker
  thread are in flight, and records are put back in input order before they are written.

The runs come from a :class:`~slamq.batch.runs.Discovery`: found by one walk of the
sources, which counts them and writes them to a temporary file, then read back from it a
chunk at a time as they are evaluated, so no list of every run is held in memory. Results
are written to ``out`` one chunk at a time (see :class:`slamq.results.ResultsFile`); what
resuming skips is kept as 64-bit digests (16 bytes per stored row).
"""

from __future__ import annotations

import itertools
import os
import threading
import uuid
import warnings
from collections import deque
from collections.abc import Iterable, Iterator
from concurrent.futures import Executor, Future, ThreadPoolExecutor, wait
from typing import Any, Callable

from slamq import native
from slamq.batch.records import EvalOptions, evaluate_run
from slamq.batch.runs import Discovery, Run
from slamq.errors import ParamError
from slamq.params import SETTINGS
from slamq.results.columns import settings_difference
from slamq.results.formats import results_format
from slamq.results.store import ResultsFile, digest64, key_digest

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
    ate_align: str = SETTINGS.ate_align.default,
    ate_max_dt: float = SETTINGS.max_dt.default,
    ate_unsorted: str = SETTINGS.unsorted.default,
    gt_align: str = SETTINGS.compare_align.default,
    gt_tolerance: float | None = SETTINGS.tolerance.default,
    gt_max_distance: float | None = SETTINGS.max_distance.default,
    rel_interpolate: bool = False,
    rel_max_gap: float | None = None,
    rel_stamp_tol: float | None = None,
    relations: Any = None,
    **params: Any,
) -> Iterator[dict[str, Any]]:
    """Evaluate many maps; yield one record per map, in input order.

    Parameters
    ----------
    sources : path, Run, an iterable of them, or a :class:`slamq.batch.runs.Discovery`
        Folders, manifest CSV files, map files or :class:`Run` objects; see
        :func:`slamq.discover_runs`. They are walked once (to count the runs and find
        each sequence's ground-truth map); the runs found wait in a temporary file until
        they are evaluated, so memory does not grow with the number of maps.
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
    rel_interpolate, rel_max_gap, rel_stamp_tol
        ``interpolate``, ``max_gap`` (seconds; None: 0.5) and ``stamp_tol`` (seconds; None:
        1e-5) of :func:`slamq.relations` (docs/spec.md 6a) for runs with a trajectory and a
        relations file (the run's ``relations``, found beside its sequence, see
        :func:`slamq.discover_runs`, or given by ``relations``): they get the ``rel_*``
        columns; a trajectory or relations file that cannot be scored sets ``rel_error``.
    relations : path or dict, optional
        The relations file of every run with a trajectory that has none of its own, or
        ``{sequence: file}``.
    **params
        Keywords of :func:`slamq.evaluate`: metric parameters, ``unknown_value``,
        ``curve``, ``verify``.

    Yields
    ------
    dict
        The record of one map: ``map, algorithm, sequence, run, trajectory, groundtruth,
        hash, unknown_value, error, seconds``, every ``MapQuality.to_dict()`` key
        (``curve`` only when asked for), ``ate_*`` (None without trajectory), ``gt_*``
        (None without a ground-truth map) and ``relations``, ``rel_*`` (None without
        relations).
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
        rel_interpolate=rel_interpolate, rel_max_gap=rel_max_gap, rel_stamp_tol=rel_stamp_tol,
        relations=relations,
    )
    if threads is not None:
        _positive("threads", threads)
    chunk = DEFAULT_CHUNK_SIZE if chunk_size is None else _positive("chunk_size", chunk_size)
    if out is not None:
        results_format(out)  # a bad suffix fails now, not after discovery
    runs = sources if isinstance(sources, Discovery) else Discovery(sources)
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


class _Done:
    """The stored, error-free runs of a results file: sorted 64-bit key digests and the
    64-bit digests of their fingerprints (16 bytes per stored row, no Python object)."""

    def __init__(self, keys: Any = None, fingerprints: Any = None) -> None:
        import numpy as np

        keys = np.asarray([] if keys is None else keys, dtype=np.int64)
        fingerprints = np.asarray([] if fingerprints is None else fingerprints,
                                  dtype=np.int64)
        order = np.argsort(keys, kind="stable")
        self.keys, self.fingerprints = keys[order], fingerprints[order]

    def get(self, key: tuple[str, str, str, str]) -> int | None:
        """The fingerprint digest stored for ``key``, or None."""
        import numpy as np

        if not len(self.keys):  # a fresh batch: no digest to take
            return None
        d = key_digest(key)
        i = int(np.searchsorted(self.keys, d))
        if i < len(self.keys) and int(self.keys[i]) == d:
            return int(self.fingerprints[i])
        return None


def _stream(
    runs: Discovery,
    options: EvalOptions,
    backend: tuple[str, Any],
    threads: int | None,
    chunk: int,
    out: Any,
    progress: ProgressFn | None,
) -> Iterator[dict[str, Any]]:
    store = ResultsFile(out) if out is not None else None
    done = _Done()
    if store is not None:
        done = _stored_done(store, runs, options)
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


def _stored_done(store: ResultsFile, runs: Discovery, options: EvalOptions) -> _Done:
    """What resuming skips (see :class:`_Done`), read from ``store`` in one streaming
    pass; warns when some stored records were computed with other settings."""
    import numpy as np

    keys: list[Any] = []  # int64 arrays of up to 65536 digests: 16 bytes per stored row
    fps: list[Any] = []
    k: list[int] = []
    f: list[int] = []
    configs: set[Any] = {options.config}
    other_keys: list[int] = []  # stored records computed with other settings
    for key, rec in store.done():
        config = rec.get("config")
        if rec.get("error") in (None, ""):
            k.append(key_digest(key))
            f.append(digest64(options.fingerprint(rec)))
            if len(k) >= 65536:
                keys.append(np.array(k, dtype=np.int64))
                fps.append(np.array(f, dtype=np.int64))
                k, f = [], []
        if config not in (None, "", options.config):
            configs.add(config)
            other_keys.append(key_digest(key))
    keys.append(np.array(k, dtype=np.int64))
    fps.append(np.array(f, dtype=np.int64))
    result = _Done(np.concatenate(keys), np.concatenate(fps))
    if other_keys:
        _warn_other_settings(store, runs, options, other_keys, configs)
    return result


def _warn_other_settings(
    store: ResultsFile, runs: Iterable[Run], options: EvalOptions, other_keys: list[int],
    configs: set[Any],
) -> None:
    """Say that a results file holds records made with other settings, and whether the
    file will mix settings once this batch is done (records of maps not in this batch)."""
    import numpy as np

    batch = np.fromiter((key_digest(r.key) for r in runs), dtype=np.int64)
    stay = int((~np.isin(np.asarray(other_keys, dtype=np.int64), batch)).sum())
    text = (
        f"{store.path}: {len(other_keys)} stored record(s) were computed with other "
        f"settings ({settings_difference(sorted(configs, key=str)) or 'unknown'}); this "
        "batch evaluates its maps again"
    )
    if stay:
        text += (
            f", but {stay} record(s) of maps outside this batch keep theirs, so the file "
            "will mix settings (use another results file)"
        )
    warnings.warn(text, UserWarning, stacklevel=5)


_WORKERS: dict[int, ThreadPoolExecutor] = {}
_WORKERS_LOCK = threading.Lock()
_WORKERS_PID = os.getpid()
#: Pools kept at once (by thread count, the most recently used). An older one is let go:
#: its threads end once no batch uses it (each leaving its ~8 KB in the core).
_KEEP_POOLS = 4


def _adopt() -> None:
    """A batch worker's first step: the Rust core runs this thread's maps on it."""
    try:
        native.adopt_thread()
    except Exception:  # noqa: BLE001 - not adopted: its maps go to a second thread, as before
        pass


def _workers(n: int) -> ThreadPoolExecutor:
    """The kept pool of ``n`` adopted batch workers (made on first use, and again in a
    forked child, where the parent's threads do not exist)."""
    global _WORKERS_PID
    with _WORKERS_LOCK:
        if _WORKERS_PID != os.getpid():
            _WORKERS.clear()
            _WORKERS_PID = os.getpid()
        pool = _WORKERS.pop(n, None)
        if pool is None:
            pool = ThreadPoolExecutor(
                max_workers=n, thread_name_prefix=f"slamq-batch-{n}", initializer=_adopt)
        _WORKERS[n] = pool  # the most recently used last
        while len(_WORKERS) > _KEEP_POOLS:
            # not shut down: a batch still running on it keeps it; when the last reference
            # goes, the executor's workers see it gone and end
            del _WORKERS[next(iter(_WORKERS))]
        return pool


def _run_local(
    runs: Iterable[Run],
    options: EvalOptions,
    done: _Done,
    executor: Executor | None,
    threads: int | None,
    chunk: int,
) -> Iterator[dict[str, Any] | None]:
    n = threads or _default_threads()
    if executor is not None:
        n = max(n, getattr(executor, "_max_workers", n))
    own = executor is None
    pool = _workers(n) if own else executor
    assert pool is not None
    group = max(1, chunk // 2)
    window = max(2 * n, chunk) + group - 1
    pending: deque[Future[dict[str, Any] | None]] = deque()
    try:
        for run in runs:
            pending.append(pool.submit(evaluate_run, run, options, done.get(run.key)))
            if len(pending) >= window:
                yield from _finished(pending, group)
        while pending:
            yield from _finished(pending, group)
    finally:
        for f in pending:
            f.cancel()
        if own:  # the maps already running finish before the batch returns
            wait(pending)


#: Longest wait for a group of finished maps before the oldest alone is taken, seconds.
_GROUP_WAIT = 0.05


def _finished(
    pending: deque[Future[dict[str, Any] | None]], group: int
) -> Iterator[dict[str, Any] | None]:
    """Take the oldest finished maps off ``pending``, in order: the first ``group`` of
    them once all are done, or after :data:`_GROUP_WAIT` those done by then (at least the
    oldest). The batch's thread thus wakes about once per group instead of once per map:
    each wake-up takes a core from a worker (2 / 1 threads, 960 dense crops, canonical
    corners off: 2-thread median 535 -> 548 maps/s over five alternating pairs)."""
    wait(list(itertools.islice(pending, group)), timeout=_GROUP_WAIT)
    yield pending.popleft().result()
    while pending and pending[0].done():
        yield pending.popleft().result()


def evaluate_chunk(
    runs: list[Run], options: EvalOptions, done: list[int | str | None], threads: int | None
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
    runs: Iterable[Run],
    options: EvalOptions,
    done: _Done,
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
        found = iter(runs)
        parts = iter(lambda: list(itertools.islice(found, chunk)), [])
        batch_id = uuid.uuid4().hex[:12]
        worker_threads = sum(client.nthreads().values()) or 1
        window = max(2, 2 * worker_threads)
        results: dict[int, list[dict[str, Any] | None]] = {}
        futures: dict[Any, int] = {}
        ac = as_completed()
        next_submit = 0
        next_yield = 0

        def submit() -> bool:
            """Send the next chunk (read from the discovery only now); False at the end."""
            nonlocal next_submit
            part = next(parts, None)
            if part is None:
                return False
            fut = client.submit(
                evaluate_chunk, part, options, [done.get(r.key) for r in part], threads,
                pure=False, key=f"slamq-batch-{batch_id}-{next_submit}",
            )
            futures[fut] = next_submit
            ac.add(fut)
            next_submit += 1
            return True

        more = True
        while more and next_submit - next_yield < window:
            more = submit()
        while next_yield < next_submit:
            fut = next(ac)
            i = futures.pop(fut)
            results[i] = fut.result()
            fut.release()
            while next_yield in results:
                yield from results.pop(next_yield)
                next_yield += 1
                if more and next_submit - next_yield < window:
                    more = submit()
    finally:
        if own_client:
            cluster = getattr(client, "cluster", None)
            client.close()
            if cluster is not None and target == "dask" and not os.environ.get(
                "DASK_SCHEDULER_ADDRESS"
            ):
                cluster.close()
