"""The three map metrics of docs/spec.md sections 2-4 of one :class:`~slamq.OccupancyMap`,
by the Rust core (``slamq.evaluate`` is this after :mod:`slamq.api` has loaded the map).

Follow one map from here: :func:`evaluate` hands the map's ``values`` and ``unknown``
buffers and the :class:`~slamq.Params` to :func:`slamq.native.evaluate`
(rust/src/bindings/maps.rs -> evaluate.rs -> proportion.rs, corners.rs, canonical/,
enclosed.rs) and wraps the integers it returns in a :class:`~slamq.MapQuality`. Ratios are
computed from those integers by :meth:`MapQuality.from_counts`, the same code
:mod:`slamq.metrics.reference` uses, so both sides agree bit for bit; the comparability
facts (saver, known box) come from the core's histogram pass
(:func:`~slamq.models.quality.facts_from_counts`), where the reference computes them with
OpenCV (:func:`~slamq.models.quality.map_facts`).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from slamq import native
from slamq.errors import ConformanceError, OutOfMemoryError, ParamError
from slamq.models import MapQuality, OccupancyMap
from slamq.models.quality import facts_from_counts, shade_source
from slamq.params import Params, check_threads, params_doc

__all__ = ["WORK_BYTES_PER_CELL", "evaluate"]

#: Peak working memory of one evaluation, in bytes per cell; the core reserves it before it
#: starts and raises :class:`~slamq.OutOfMemoryError` when it cannot (rust/src/memory.rs).
WORK_BYTES_PER_CELL: int = native.WORK_BYTES_PER_CELL


def evaluate(
    grid: OccupancyMap,
    *,
    params: Params | None = None,
    curve: bool = False,
    verify: bool = False,
    threads: int | None = None,
    **metric_params: Any,
) -> MapQuality:
    """Compute the three map metrics of docs/spec.md sections 2-4 with the Rust core.

    Parameters
    ----------
    grid : OccupancyMap
        The map (:func:`slamq.load_map` reads one; :func:`slamq.evaluate` takes a path or
        an image array too).
    params : Params, optional
        All metric parameters at once; or give them one by one as keywords (below).
    curve : bool, default False
        Keep the whole enclosed-area curve ``count_u`` in the result.
    verify : bool, default False
        Also run :mod:`slamq.metrics.reference` and raise :class:`slamq.ConformanceError` on
        any difference (slow: the reference labels the map once per sweep value).
    threads : int, optional
        Cap on the Rust worker threads for this call (default: all cores; at most
        :data:`slamq.params.MAX_THREADS`). Results do not depend on it.
    {params}

    Returns
    -------
    MapQuality

    Examples
    --------
    >>> import numpy as np, slamq
    >>> from slamq.metrics.evaluate import evaluate
    >>> img = np.full((20, 20), 254, np.uint8)
    >>> img[8:12, 8:12] = 0          # a square obstacle in open space
    >>> q = evaluate(slamq.OccupancyMap(img, np.zeros_like(img, bool)))
    >>> q.occupied, q.corners, q.enclosed_areas
    (16, 4, 0)
    >>> q.corners == slamq.evaluate(img).corners
    True
    """
    if not isinstance(grid, OccupancyMap):
        raise ParamError(f"evaluate takes an OccupancyMap, not {type(grid).__name__}; "
                         "slamq.evaluate reads files and arrays")
    params = Params.resolve(params, metric_params)
    n_threads = check_threads(threads)
    try:
        raw = native.evaluate(grid.values, grid.unknown, params, n_threads, grid.resolution,
                             shade_source(grid))
    except MemoryError as exc:
        h, w = grid.shape
        raise OutOfMemoryError(f"{grid.source}: {exc} of a {h} x {w} map (up to "
                               f"{WORK_BYTES_PER_CELL} bytes per cell)") from None
    result = MapQuality.from_counts(
        source=grid.source,
        shape=grid.shape,
        known=raw.known,
        occupied=raw.occupied,
        sum_darkness=raw.sum_darkness,
        corners=raw.corners,
        curve=raw.curve,
        params=params,
        keep_curve=curve or verify,
        resolution=grid.resolution,
        corners_canonical=raw.corners_canonical,
        wall_angle=raw.wall_angle,
        wall_harmonics=raw.wall_harmonics,
        facts=facts_from_counts(grid, raw.known_levels, raw.unknown_shade, raw.known_box),
    )
    if verify:
        from slamq.metrics import reference

        expected = reference.evaluate(grid, curve=True, params=params)
        diffs = result.differences(expected)
        if diffs:
            raise ConformanceError(
                f"{grid.source}: Rust core and slamq.metrics.reference disagree: "
                + "; ".join(diffs)
            )
        if not curve:
            result = replace(result, curve=None)
    return result


evaluate.__doc__ = params_doc(evaluate.__doc__)
