"""One result record per map: the columns, the content hash, and the per-map worker.

:func:`evaluate_run` is what every executor (thread pool, process pool, Dask worker) runs
for one :class:`~slamq.batch.discover.Run`. It never raises for a bad map: the failure
becomes the record's ``error`` (``"file: reason"``) and the batch goes on.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import json
import math
import os
import stat
import time
from pathlib import Path
from typing import Any

from slamq.batch.runs import Run, is_ground_truth
from slamq.errors import MapError, ParamError, SlamqError
from slamq.models.comparison import COMPARISON_FIGURES
from slamq.params import SETTINGS, Params
from slamq.results.columns import ATE_STATS, columns
from slamq.results.store import digest64
from slamq.sources import formats
from slamq.sources.files import (
    MAX_IMAGE_BYTES,
    MAX_YAML_BYTES,
    YAML_SUFFIXES,
    read_once,
    read_regular_file,
)
from slamq.sources.trajectories import load_pair

__all__ = ["EvalOptions", "content_hash", "evaluate_run", "map_files"]

_READ_CHUNK = 1 << 20


def map_files(path: os.PathLike[str] | str) -> list[Path]:
    """The files a map is made of, as its format says
    (:func:`slamq.sources.formats.map_files`): a YAML and the image it names, an MRPT grid
    and its limits, an image or bag file alone, every file of a ROS 2 bag folder.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (d / "m.yaml").write_text("image: m.pgm\\nresolution: 0.05\\n")
    >>> [p.name for p in map_files(d / "m.yaml")]
    ['m.yaml', 'm.pgm']
    """
    return formats.map_files(path)


def content_hash(path: os.PathLike[str] | str) -> str:
    """Hex SHA-1 of a map's bytes: each of its files (:func:`map_files`), length-prefixed.

    SHA-1 here is a fast content fingerprint (hardware accelerated, about 2 GB/s), not a
    security measure. Files are read through :func:`slamq.sources.files.read_regular_file`
    (size budgets checked before a byte is hashed; inside
    :func:`~slamq.sources.files.read_once` the loader decodes the very bytes hashed here),
    except those of a format whose own library reads them (bags): these are hashed in
    chunks. A file that cannot be read raises ``OSError`` or
    :class:`~slamq.errors.MapError`.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (d / "a.pgm").write_bytes(b"P5 1 1 255 \\x00")
    >>> content_hash(d / "a.pgm") == content_hash(d / "a.pgm"), len(content_hash(d / "a.pgm"))
    (True, 40)
    """
    path = Path(path)
    h = hashlib.sha1(usedforsecurity=False)
    fmt = formats.format_of(path)
    parts = [path] if fmt is None else fmt.files(path)
    for f in parts:
        if (fmt is not None and fmt.large) or f.is_dir():
            _hash_file(h, f)
        elif f.suffix.lower() in YAML_SUFFIXES:
            _hash_bytes(h, read_regular_file(f, "a map YAML", MAX_YAML_BYTES))
        else:
            _hash_bytes(h, read_regular_file(f, "an image", MAX_IMAGE_BYTES))
    return h.hexdigest()


def _hash_bytes(h: Any, data: bytes) -> None:
    h.update(len(data).to_bytes(8, "little"))
    h.update(data)


def _hash_file(h: Any, path: Path) -> None:
    """Add the size and the bytes of one regular file to ``h``, read in chunks (a bag file
    can be gigabytes); a FIFO or device would block or never end, so it is refused."""
    if not stat.S_ISREG(os.stat(path).st_mode):
        raise OSError(f"{path}: not a regular file")
    with open(path, "rb") as fh:
        size = os.fstat(fh.fileno()).st_size
        h.update(size.to_bytes(8, "little"))
        seen = 0
        while chunk := fh.read(_READ_CHUNK):
            seen += len(chunk)
            h.update(chunk)
    if seen != size:
        raise OSError(f"{path}: changed while being read")


def _signature(path: Path) -> list[tuple[int, int, int, int]] | None:
    """(device, inode, size, mtime) of every file of a bag; None when one cannot be read."""
    try:
        return [(st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns)
                for st in (os.stat(f) for f in map_files(path))]
    except (OSError, ValueError):
        return None


class EvalOptions:
    """The per-map settings of a batch: metric parameters and what else to compute.

    Parameters
    ----------
    params : dict
        Keywords of :func:`slamq.evaluate`: the :class:`slamq.Params` fields,
        ``unknown_value``, ``curve`` and ``verify``.
    ate_align : str
        Alignment for the trajectory error (``se2`` by default; see SPEC section 6).
    ate_max_dt : float
        Largest timestamp difference when associating poses, seconds.
    ate_unsorted : {"error", "last", "sort"}
        What to do with a trajectory whose timestamps go backwards (a restarted log):
        record an ``ate_error`` (default), keep the rows after the last restart, or sort.
    gt_align, gt_tolerance, gt_max_distance
        ``align``, ``tolerance`` and ``max_distance`` of :func:`slamq.compare`, for runs
        with a ground-truth map (``gt_*`` columns).
    rel_interpolate, rel_max_gap, rel_stamp_tol
        ``interpolate``, ``max_gap`` and ``stamp_tol`` of :func:`slamq.relations`, for runs
        with a trajectory and relations (``rel_*`` columns; docs/spec.md 6a); None: the
        function's defaults (0.5 s, 1e-5 s).
    relations : path or dict, optional
        The relations file of every run with a trajectory and none of its own, or
        ``{sequence: file}``.
    """

    _EVAL_KEYS = frozenset({"unknown_value", "curve", "verify"})

    def __init__(
        self, params: dict[str, Any] | None = None, *,
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
    ) -> None:
        params = dict(params or {})
        extra = {k: params.pop(k) for k in list(params) if k in self._EVAL_KEYS}
        self.params = Params.from_kwargs(**params)
        uv = extra.get("unknown_value")
        lo, hi = SETTINGS.unknown_value.low, SETTINGS.unknown_value.high
        bad_uv = isinstance(uv, bool) or not isinstance(uv, int) or not lo <= uv <= hi
        if uv is not None and bad_uv:
            raise ParamError(f"unknown_value must be an integer in {lo}..{hi}, got {uv!r}")
        self.unknown_value: int | None = uv
        self.curve = bool(extra.get("curve", False))
        self.verify = bool(extra.get("verify", False))
        self.ate_align = str(ate_align)
        self.ate_max_dt = float(ate_max_dt)
        if ate_unsorted not in SETTINGS.unsorted.choices:
            raise ParamError(
                f"ate_unsorted must be 'error', 'last' or 'sort', not {ate_unsorted!r}"
            )
        self.ate_unsorted = ate_unsorted
        if gt_align not in SETTINGS.compare_align.choices:
            raise ParamError(f"gt_align must be one of "
                             f"{', '.join(SETTINGS.compare_align.choices)}, "
                             f"got {gt_align!r}")
        for name, value in (("gt_tolerance", gt_tolerance),
                            ("gt_max_distance", gt_max_distance)):
            if value is not None and (isinstance(value, bool) or not isinstance(
                    value, (int, float)) or not value > 0):
                raise ParamError(f"{name} must be a positive number, got {value!r}")
        self.gt_align = gt_align
        self.gt_tolerance = gt_tolerance
        self.gt_max_distance = gt_max_distance
        for name, value in (("rel_max_gap", rel_max_gap), ("rel_stamp_tol", rel_stamp_tol)):
            if value is not None and (isinstance(value, bool) or not isinstance(
                    value, (int, float)) or not math.isfinite(value) or value < 0):
                raise ParamError(f"{name} must be a number >= 0, got {value!r}")
        self.rel_interpolate = bool(rel_interpolate)
        self.rel_max_gap = None if rel_max_gap is None else float(rel_max_gap)
        self.rel_stamp_tol = None if rel_stamp_tol is None else float(rel_stamp_tol)
        self.relations = _relations_option(relations)
        #: ``threads`` of each ``slamq.evaluate`` call: one core per map, the maps in
        #: parallel (each calling thread gets its own 1-thread pool in the core).
        self.core_threads: int | None = 1
        self._config: str | None = None
        self._param_fields: dict[str, Any] | None = None

    def __getstate__(self) -> dict[str, Any]:
        return dict(self.__dict__)

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update({"_config": None, "_param_fields": None, **state})

    def columns(self) -> tuple[str, ...]:
        return columns(self.curve)

    @property
    def param_fields(self) -> dict[str, Any]:
        """The ``param_*`` columns of every record (built once per batch, not per map)."""
        if self._param_fields is None:
            self._param_fields = {f"param_{k}": v for k, v in self.params.to_dict().items()}
        return self._param_fields

    @property
    def config(self) -> str:
        """Every setting that changes a record, as a short JSON string (stored per record):
        the metric parameters, ``unknown_value``, ``curve`` and the ATE options. Built once
        per batch (the options do not change while it runs)."""
        if self._config is None:
            self._config = self._config_json()
        return self._config

    def _config_json(self) -> str:
        return json.dumps(
            {
                "params": self.params.to_dict(),
                "unknown_value": self.unknown_value,
                "curve": self.curve,
                "ate": [self.ate_align, self.ate_max_dt, self.ate_unsorted],
                "gt": [self.gt_align, self.gt_tolerance, self.gt_max_distance],
                # only when not the defaults: records made before relations existed stay
                **({"rel": self._rel_settings} if self._rel_settings != _REL_DEFAULTS
                   else {}),
            },
            sort_keys=True,
            separators=(",", ":"),
        )

    @property
    def _rel_settings(self) -> list[Any]:
        return [self.rel_interpolate, self.rel_max_gap, self.rel_stamp_tol]

    def with_relations(self, run: Run) -> Run:
        """``run`` with the relations file the batch names for it (``relations``), unless it
        has its own; only a run with a trajectory gets one."""
        if run.relations is not None or self.relations is None or run.trajectory is None:
            return run
        rel = self.relations.get(run.sequence) if isinstance(self.relations, dict) \
            else self.relations
        return run if rel is None else dataclasses.replace(run, relations=rel)

    @staticmethod
    def fingerprint(record: dict[str, Any]) -> str:
        """What must match for a stored record to count as done (besides having no
        error): the map's content hash, the settings and the trajectory files."""
        return json.dumps(
            [
                record.get("hash"),
                record.get("config"),
                record.get("trajectory") or None,
                record.get("groundtruth") or None,
            ] + ([record["gt_map"]] if record.get("gt_map") else [])
            + ([["relations", record["relations"]]] if record.get("relations") else [])
        )

    def expected_fingerprint(self, run: Run, digest: str | None) -> str:
        return self.fingerprint(
            {"hash": digest, "config": self.config, "trajectory": _str(run.trajectory),
             "groundtruth": _str(run.groundtruth), "gt_map": _str(_gt_map(run)),
             "relations": _str(_relations(run))}
        )


def _str(p: Path | None) -> str | None:
    return None if p is None else str(p)


#: ``interpolate``, ``max_gap``, ``stamp_tol`` of :func:`slamq.relations` by default.
_REL_DEFAULTS = [False, None, None]


def _relations_option(value: Any) -> Path | dict[str, Path] | None:
    """``relations=`` of a batch: one file, or ``{sequence: file}``."""
    if value is None:
        return None
    if isinstance(value, (str, os.PathLike)):
        return Path(value)
    if isinstance(value, dict) and all(isinstance(v, (str, os.PathLike))
                                       for v in value.values()):
        return {str(k): Path(v) for k, v in value.items()}
    raise ParamError(f"relations must be a path or a mapping sequence -> path, got {value!r}")


def _relations(run: Run) -> Path | None:
    """The relations the run is scored against (none without a trajectory, or for a
    reference map)."""
    if run.trajectory is None or is_ground_truth(run.algorithm):
        return None
    return run.relations


def _message(where: str, exc: BaseException) -> str:
    msg = str(exc) or type(exc).__name__
    if not isinstance(exc, SlamqError):
        msg = f"{type(exc).__name__}: {msg}"
    msg = " ".join(msg.split())  # one line
    return msg if where in msg else f"{where}: {msg}"


def evaluate_run(
    run: Run, options: EvalOptions, done: int | str | None = None
) -> dict[str, Any] | None:
    """Evaluate one run and return its record, or None when ``done`` says it is current.

    Parameters
    ----------
    run : Run
    options : EvalOptions
    done : int or str, optional
        The fingerprint of a stored, error-free record of this run (resume), or its
        :func:`slamq.results.store.digest64` (what a batch keeps). When the map's content
        hash gives the same fingerprint, nothing is evaluated.

    Returns
    -------
    dict or None
        Keys :func:`columns`; ``error`` is None or ``"file: reason"``.

    Examples
    --------
    >>> rec = evaluate_run(Run("no/such/map.yaml", "a", "s"), EvalOptions())
    >>> rec["error"]
    'no/such/map.yaml: no such file or directory'
    """
    t0 = time.perf_counter()
    run = options.with_relations(run)
    rec: dict[str, Any] = dict.fromkeys(options.columns())
    rec.update(
        map=str(run.map), algorithm=run.algorithm, sequence=run.sequence, run=run.run,
        trajectory=_str(run.trajectory), groundtruth=_str(run.groundtruth),
        unknown_value=options.unknown_value, config=options.config,
        gt_map=_str(_gt_map(run)), relations=_str(_relations(run)), scans=_str(run.scans),
    )
    rec.update(options.param_fields)
    where = str(run.map)
    # One read: the map's files are hashed and decoded from the same bytes (read_once), and
    # a bag, read twice, must look the same (inode, size, mtime) before and after.
    fmt = formats.format_of(run.map)
    twice = Path(run.map).is_dir() or (fmt is not None and fmt.large)  # read by its library
    with read_once():
        before = _signature(run.map) if twice else None
        try:
            digest: str | None = content_hash(run.map)
        except (OSError, MapError):
            digest = None  # unreadable: the loader below names the file and the reason
        rec["hash"] = digest
        if digest is not None and done is not None:
            expected = options.expected_fingerprint(run, digest)
            if expected == done or (isinstance(done, int) and digest64(expected) == done):
                return None
        try:
            from slamq.api import evaluate

            q = evaluate(
                str(run.map), threads=options.core_threads, curve=options.curve,
                verify=options.verify,
                unknown_value=options.unknown_value, params=options.params,
            )
            d = q.to_dict()
            if not options.curve:
                d.pop("curve", None)
            rec.update(d)
        except Exception as exc:  # noqa: BLE001 - a bad map is a row, never a crash
            rec["error"] = _message(where, exc)
        if rec["error"] is None and _gt_map(run) is not None:  # the same bytes again
            rec.update(_gt_fields(run, options))
    if twice and rec["error"] is None and _signature(run.map) != before:
        rec["error"] = f"{where}: changed while being read; not scored (run the batch again)"
    if rec["error"] is None and run.trajectory is not None and run.groundtruth is not None:
        rec.update(_ate_fields(run, options))
    if rec["error"] is None and _relations(run) is not None:
        rec.update(_rel_fields(run, options))
    rec["seconds"] = time.perf_counter() - t0
    return rec


def _ate_fields(run: Run, options: EvalOptions) -> dict[str, Any]:
    """``ate_*`` of the run's trajectory against its ground truth (SPEC section 6)."""
    from slamq.metrics.ate import ate

    assert run.trajectory is not None and run.groundtruth is not None
    try:
        est, gt = load_pair(run.trajectory, run.groundtruth, options.ate_unsorted)
        res = ate(gt, est, align=options.ate_align, max_dt=options.ate_max_dt)
    except Exception as exc:  # noqa: BLE001 - a bad trajectory is a field, never a crash
        return {"ate_error": _message(str(run.trajectory), exc)}
    out: dict[str, Any] = {f"ate_{s}": float(getattr(res, s)) for s in ATE_STATS if s != "n"}
    out["ate_n"] = int(res.n)
    return out


@functools.lru_cache(maxsize=16)
def _read_relations(path: str, size: int, mtime_ns: int) -> Any:
    """A relations file, read once per batch (the same file scores every run of its
    sequence; its size and time in the key: a changed file is read again)."""
    from slamq.sources.relations import read_relations

    return read_relations(path)


def _rel_fields(run: Run, options: EvalOptions) -> dict[str, Any]:
    """``rel_*``: the run's trajectory against its sequence's relations (SPEC section 6a)."""
    from slamq.metrics.relations import relations
    from slamq.sources.trajectories import load_trajectory

    rel_path = _relations(run)
    assert rel_path is not None and run.trajectory is not None
    try:
        st = os.stat(rel_path)
        rel = _read_relations(str(rel_path), st.st_size, st.st_mtime_ns)
    except Exception as exc:  # noqa: BLE001 - a bad relations file is a field, never a crash
        return {"rel_error": _message(str(rel_path), exc)}
    try:
        est = load_trajectory(run.trajectory, unsorted=options.ate_unsorted)
        kw: dict[str, Any] = {"interpolate": options.rel_interpolate}
        if options.rel_max_gap is not None:
            kw["max_gap"] = options.rel_max_gap
        if options.rel_stamp_tol is not None:
            kw["stamp_tol"] = options.rel_stamp_tol
        res = relations(est, rel, **kw)
    except Exception as exc:  # noqa: BLE001 - a bad trajectory is a field, never a crash
        return {"rel_error": _message(str(run.trajectory), exc)}
    return {f"rel_{k}": v for k, v in res.stats().items()}


def _gt_map(run: Run) -> Path | None:
    """The ground-truth map to compare the run with (never for a reference run)."""
    return None if is_ground_truth(run.algorithm) else run.gt_map


def _gt_fields(run: Run, options: EvalOptions) -> dict[str, Any]:
    """``gt_*``: the run's map against its sequence's ground-truth map (SPEC section 7)."""
    from slamq.api import compare

    gt = _gt_map(run)
    assert gt is not None
    try:
        c = compare(str(run.map), str(gt), align=options.gt_align,
                    tolerance=options.gt_tolerance, max_distance=options.gt_max_distance,
                    threads=options.core_threads, unknown_value=options.unknown_value)
    except Exception as exc:  # noqa: BLE001 - a bad ground truth is a field, never a crash
        return {"gt_error": _message(str(gt), exc)}
    return {f"gt_{f}": getattr(c, f) for f in COMPARISON_FIGURES}
