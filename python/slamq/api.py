"""The public functions that take files: paths (and image arrays) become models here, then
one metric runs on them.

This is the one edge between reading and measuring: :mod:`slamq.sources` turns a path
into an :class:`~slamq.OccupancyMap` or a :class:`~slamq.Trajectory`, and the metric of
:mod:`slamq.metrics` (which takes models only and never reads a file) computes the
numbers. ``slamq.evaluate``, ``slamq.compare``, ``slamq.consensus``, ``slamq.register``,
``slamq.register_many``, ``slamq.ate``,
``slamq.rpe`` and ``slamq.ate_runs`` are the functions below; each takes every keyword of
its metric (same names, same defaults: the metric's signature is this one's).

>>> import numpy as np, slamq
>>> img = np.full((20, 20), 254, np.uint8)
>>> img[8:12, 8:12] = 0
>>> slamq.evaluate(img).corners
4
"""

from __future__ import annotations

import inspect
import os
import warnings
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any, TypeVar, Union

from slamq.errors import MapWarning, OutOfMemoryError, SlamqError
from slamq.metrics.agreement import Agreement
from slamq.metrics.agreement import agreement as agreement_of
from slamq.metrics.ate import ErrorResult, RunsResult
from slamq.metrics.ate import ate as ate_of
from slamq.metrics.ate import ate_runs as ate_runs_of
from slamq.metrics.ate import rpe as rpe_of
from slamq.metrics.compare import compare as compare_of
from slamq.metrics.consensus import Consensus
from slamq.metrics.consensus import consensus as consensus_of
from slamq.metrics.evaluate import evaluate as evaluate_of
from slamq.metrics.register import register as register_of
from slamq.metrics.register import register_many as register_many_of
from slamq.models import MapComparison, MapQuality, OccupancyMap, Registration, Trajectory
from slamq.sources.maps import load_map
from slamq.sources.trajectories import load_trajectory

__all__ = ["MapSource", "TrajLike", "agreement", "ate", "ate_runs", "compare", "consensus",
           "evaluate", "register", "register_many", "rpe"]

#: What the map functions accept: a path, an :class:`OccupancyMap`, or a numpy image array.
MapSource = Union[str, os.PathLike, OccupancyMap, Any]
#: What the trajectory functions accept: a :class:`Trajectory` (a path: deprecated).
TrajLike = Union[Trajectory, str, Path]

_F = TypeVar("_F", bound=Callable[..., Any])


def _like(metric: Callable[..., Any], sources: Sequence[inspect.Parameter]) -> Callable[[_F], _F]:
    """Give the wrapped function the metric's keywords in its signature (after its own
    ``sources``), so that ``help()`` lists them with the metric's defaults."""
    def wrap(fn: _F) -> _F:
        own = [p for p in inspect.signature(metric).parameters.values()
               if p.kind in (p.KEYWORD_ONLY, p.VAR_KEYWORD)]
        extra = [p for p in sources if p.kind is p.KEYWORD_ONLY]
        pos = [p for p in sources if p.kind is not p.KEYWORD_ONLY]
        kw = [p for p in own if p.kind is p.KEYWORD_ONLY] + extra
        var = [p for p in own if p.kind is p.VAR_KEYWORD]
        fn.__signature__ = inspect.Signature(  # type: ignore[attr-defined]
            pos + kw + var, return_annotation=inspect.signature(fn).return_annotation)
        return fn
    return wrap


def _param(name: str, kind: Any = inspect.Parameter.POSITIONAL_OR_KEYWORD,
           default: Any = inspect.Parameter.empty) -> inspect.Parameter:
    return inspect.Parameter(name, kind, default=default)


_UNKNOWN = _param("unknown_value", inspect.Parameter.KEYWORD_ONLY, None)


def _load(source: MapSource, unknown_value: int | None) -> OccupancyMap:
    """:func:`slamq.load_map`, a ``MemoryError`` while loading turned into an
    :class:`~slamq.OutOfMemoryError` naming the map."""
    try:
        return load_map(source, unknown_value=unknown_value)
    except MemoryError as exc:
        if isinstance(exc, SlamqError):
            raise
        where = source if isinstance(source, (str, os.PathLike)) else getattr(
            source, "source", "<array>")
        raise OutOfMemoryError(f"{os.fspath(where)}: out of memory while loading the map"
                               ) from None


@_like(evaluate_of, [_param("source"), _UNKNOWN])
def evaluate(source: MapSource, *, unknown_value: int | None = None,
             **options: Any) -> MapQuality:
    """The three map metrics of a map file, image array or :class:`~slamq.OccupancyMap`.

    Parameters
    ----------
    source : path, OccupancyMap, or numpy array
        A map file (YAML or image), an :class:`OccupancyMap`, or a 2-D uint8 image array
        (loaded with the image defaults of :func:`slamq.load_map`).
    unknown_value : int, optional
        Passed to :func:`slamq.load_map` when ``source`` is a path or an image array.
    **options
        Every keyword of :func:`slamq.metrics.evaluate.evaluate`: ``params``, ``curve``,
        ``verify``, ``threads`` and the metric parameters (:class:`slamq.Params`).

    Returns
    -------
    MapQuality

    Examples
    --------
    >>> import numpy as np, slamq
    >>> img = np.full((20, 20), 254, np.uint8)
    >>> img[8:12, 8:12] = 0          # a square obstacle in open space
    >>> q = slamq.evaluate(img)
    >>> q.occupied, q.corners, q.enclosed_areas
    (16, 4, 0)
    >>> slamq.evaluate(img, min_area=4) == slamq.evaluate(img, params=slamq.Params(min_area=4))
    True
    """
    return evaluate_of(_load(source, unknown_value), **options)


@_like(compare_of, [_param("estimate"), _param("ground_truth"), _UNKNOWN])
def compare(estimate: MapSource, ground_truth: MapSource, *, unknown_value: int | None = None,
            **options: Any) -> MapComparison:
    """A map against a ground-truth map (docs/spec.md section 7), from files or arrays.

    Parameters
    ----------
    estimate, ground_truth : path, OccupancyMap, or numpy array
        Anything :func:`slamq.load_map` reads.
    unknown_value : int, optional
        Passed to :func:`slamq.load_map` for both maps.
    **options
        Every keyword of :func:`slamq.metrics.compare.compare` (``tolerance``,
        ``occupied_threshold``, ``align``, ``max_distance``, ``cells``, ``threads``,
        ``min_fit_precision``, ``cells_box``).

    Returns
    -------
    MapComparison

    Warns
    -----
    slamq.MapWarning
        When the alignment fitted poorly (``MapComparison.note`` says how, and which
        alignment was used).

    Examples
    --------
    >>> import numpy as np, slamq
    >>> gt = np.full((40, 40), 254, np.uint8)
    >>> gt[10, 5:35] = 0; gt[10:30, 5] = 0               # two walls
    >>> est = gt.copy(); est[10:30, 5] = 254              # the estimate lacks one
    >>> c = slamq.compare(est, gt, align="origin")
    >>> round(c.precision, 3), round(c.recall, 3), c.reverse
    (1.0, 0.633, 0.0)
    """
    est = _load(estimate, unknown_value)
    gt = _load(ground_truth, unknown_value)
    c = compare_of(est, gt, **options)
    if c.note:
        hint = "; pass align='search' (or 'auto')" if "fits better" in c.note else ""
        warnings.warn(MapWarning(f"{c.estimate} vs {c.ground_truth}: {c.note}{hint}"),
                      stacklevel=2)
    return c


@_like(consensus_of, [_param("maps")])
def consensus(maps: Mapping[str, MapSource] | Sequence[MapSource],
              **options: Any) -> Consensus:
    """Each of several maps (files, arrays or models) against the consensus of the others.

    Parameters
    ----------
    maps : mapping of name to map, or sequence of maps
        At least 3 maps, anything :func:`slamq.load_map` reads; a sequence is named
        ``"0"``, ``"1"``...
    **options
        Every keyword of :func:`slamq.metrics.consensus.consensus`.

    Returns
    -------
    Consensus

    Examples
    --------
    >>> import numpy as np, slamq
    >>> img = np.full((30, 30), 254, np.uint8); img[5, 5:25] = 0; img[5:25, 5] = 0
    >>> sorted(slamq.consensus([img, img, img]).scores)
    ['0', '1', '2']
    """
    named = (dict(maps) if isinstance(maps, Mapping)
             else {str(i): m for i, m in enumerate(maps)})
    return consensus_of({str(k): _load(v, None) for k, v in named.items()}, **options)


@_like(agreement_of, [_param("maps")])
def agreement(maps: Mapping[str, MapSource] | Sequence[MapSource],
              **options: Any) -> Agreement:
    """Each of several maps of one place (files, arrays or models) scored by the others.

    Parameters
    ----------
    maps : mapping of name to map, or sequence of maps
        At least 2 maps, anything :func:`slamq.load_map` reads; a sequence is named
        ``"0"``, ``"1"``...
    **options
        Every keyword of :func:`slamq.metrics.agreement.agreement`.

    Returns
    -------
    Agreement

    Examples
    --------
    >>> import numpy as np, slamq
    >>> img = np.full((30, 30), 254, np.uint8); img[5, 5:25] = 0; img[5:25, 5] = 0
    >>> a = slamq.agreement([img, img, img], align="origin")
    >>> a.support["0"], a.majority
    (1.0, True)
    """
    named = (dict(maps) if isinstance(maps, Mapping)
             else {str(i): m for i, m in enumerate(maps)})
    return agreement_of({str(k): _load(v, None) for k, v in named.items()}, **options)


@_like(register_of, [_param("moving"), _param("fixed"), _UNKNOWN])
def register(moving: MapSource, fixed: MapSource, *, unknown_value: int | None = None,
             **options: Any) -> Registration:
    """Register a map onto another map of the same place (files, arrays or models).

    Parameters
    ----------
    moving, fixed : path, OccupancyMap, or numpy array
        The two maps (read with :func:`slamq.load_map`).
    unknown_value : int, optional
        Passed to :func:`slamq.load_map` for paths and arrays.
    **options
        Every keyword of :func:`slamq.metrics.register.register`.

    Returns
    -------
    Registration

    Examples
    --------
    >>> import numpy as np, slamq
    >>> img = np.full((80, 100), 254, np.uint8)
    >>> img[10, 10:90] = img[70, 10:90] = img[10:71, 10] = img[10:71, 90] = 0
    >>> img[10:40, 50] = img[40, 30:51] = 0
    >>> r = slamq.register(np.rot90(img), img)
    >>> r.ok, round(abs(np.degrees(r.theta)))
    (True, 90)
    """
    return register_of(_load(moving, unknown_value), _load(fixed, unknown_value), **options)


@_like(register_many_of, [_param("maps"), _UNKNOWN])
def register_many(maps: Mapping[str, MapSource] | Sequence[MapSource], *,
                  unknown_value: int | None = None,
                  **options: Any) -> dict[tuple[str, str], Registration]:
    """Register every pair of several maps of one place (files, arrays or models).

    Parameters
    ----------
    maps : mapping of name to map, or sequence of maps
        Paths, :class:`OccupancyMap` objects or image arrays; a sequence is named ``"0"``,
        ``"1"``...
    unknown_value : int, optional
        Passed to :func:`slamq.load_map` for paths and arrays.
    **options
        Every keyword of :func:`slamq.metrics.register.register_many`.

    Returns
    -------
    dict of (moving, fixed) to Registration

    Examples
    --------
    >>> import numpy as np, slamq
    >>> img = np.full((80, 100), 254, np.uint8)
    >>> img[10, 10:90] = img[70, 10:90] = img[10:71, 10] = img[10:71, 90] = 0
    >>> img[10:40, 50] = img[40, 30:51] = 0
    >>> regs = slamq.register_many({"a": img, "b": np.rot90(img)})
    >>> sorted(regs), regs["b", "a"].ok
    ([('a', 'b'), ('b', 'a')], True)
    """
    named = (dict(maps) if isinstance(maps, Mapping)
             else {str(i): m for i, m in enumerate(maps)})
    return register_many_of({str(k): _load(v, unknown_value) for k, v in named.items()},
                            **options)


def _trajectory(x: TrajLike, what: str) -> Trajectory:
    """A Trajectory as it is; a path read (deprecated, with a warning)."""
    if isinstance(x, (str, Path)):
        # Deprecated: the metrics work on Trajectory objects; reading files is the sources'
        # job (slamq.load_trajectory). Kept, with a warning, so old callers still work.
        warnings.warn(
            f"passing a file path as {what} is deprecated; read it with "
            "slamq.load_trajectory(path) first", DeprecationWarning, stacklevel=3)
        return load_trajectory(x)
    return x  # type: ignore[return-value]  # the metric names anything else


@_like(ate_of, [_param("gt"), _param("est")])
def ate(gt: TrajLike, est: TrajLike, **options: Any) -> ErrorResult:
    """Absolute trajectory error (:func:`slamq.metrics.ate.ate`); paths still work,
    deprecated.

    Parameters
    ----------
    gt, est : Trajectory or path
        Ground truth and estimate (read them with :func:`slamq.load_trajectory`).
    **options
        Every keyword of :func:`slamq.metrics.ate.ate` (``align``, ``max_dt``, ``offset``).

    Returns
    -------
    ErrorResult

    Examples
    --------
    >>> import numpy as np, slamq
    >>> t = np.arange(20.0)
    >>> gt = slamq.Trajectory.from_xy_yaw(t, t, np.sin(t))
    >>> slamq.ate(gt, gt, align="none").rmse
    0.0
    """
    return ate_of(_trajectory(gt, "gt"), _trajectory(est, "est"), **options)


@_like(rpe_of, [_param("gt"), _param("est")])
def rpe(gt: TrajLike, est: TrajLike, **options: Any) -> ErrorResult:
    """Relative pose error (:func:`slamq.metrics.ate.rpe`); paths still work, deprecated.

    Parameters
    ----------
    gt, est : Trajectory or path
        Ground truth and estimate (read them with :func:`slamq.load_trajectory`).
    **options
        Every keyword of :func:`slamq.metrics.ate.rpe`.

    Returns
    -------
    ErrorResult

    Examples
    --------
    >>> import numpy as np, slamq
    >>> t = np.arange(21.0)
    >>> gt = slamq.Trajectory.from_xy_yaw(t, t, 0 * t)
    >>> slamq.rpe(gt, gt, delta=1).rmse
    0.0
    """
    return rpe_of(_trajectory(gt, "gt"), _trajectory(est, "est"), **options)


@_like(ate_runs_of, [_param("gt"), _param("ests")])
def ate_runs(gt: TrajLike, ests: Sequence[TrajLike], **options: Any) -> RunsResult:
    """ATE of repeated runs against one ground truth (:func:`slamq.metrics.ate.ate_runs`);
    paths still work, deprecated.

    Parameters
    ----------
    gt : Trajectory or path
    ests : sequence of Trajectory or path
    **options
        Every keyword of :func:`slamq.metrics.ate.ate_runs`.

    Returns
    -------
    RunsResult

    Examples
    --------
    >>> import numpy as np, slamq
    >>> t = np.arange(20.0)
    >>> gt = slamq.Trajectory.from_xy_yaw(t, t, np.sin(t))
    >>> slamq.ate_runs(gt, [gt, gt], align="none").mean
    0.0
    """
    return ate_runs_of(_trajectory(gt, "gt"), [_trajectory(e, "est") for e in ests],
                         **options)
