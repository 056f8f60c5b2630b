"""``slamq.evaluate``: the three map metrics of docs/spec.md sections 2-4, by the Rust core.

Follow one map from here: :func:`evaluate` loads it (:func:`slamq.load_map`), hands the
``values`` and ``unknown`` buffers and the :class:`~slamq.Params` to ``slamq._core.evaluate``
(rust/src/bindings/maps.rs -> evaluate.rs -> proportion.rs, corners.rs, canonical.rs, enclosed.rs)
and wraps the integers it returns in a :class:`~slamq.MapQuality`. Ratios are computed from
those integers by :meth:`MapQuality.from_counts`, the same code :mod:`slamq.metrics.reference`
uses, so both sides agree bit for bit; the comparability facts (saver, known box) come from
the core's histogram pass (:func:`~slamq.models.quality.facts_from_counts`), where the
reference computes them with OpenCV (:func:`~slamq.models.quality.map_facts`).
"""

from __future__ import annotations

import os
from dataclasses import replace
from typing import Any, Union

from slamq.errors import ConformanceError, OutOfMemoryError, SlamqError
from slamq.models import MapQuality, OccupancyMap
from slamq.models.quality import facts_from_counts, shade_source
from slamq.params import Params, check_threads, params_doc
from slamq.sources import load_map

__all__ = ["MapSource", "WORK_BYTES_PER_CELL", "evaluate"]

#: Peak working memory of one evaluation, in bytes per cell; the core reserves it before it
#: starts and raises :class:`~slamq.OutOfMemoryError` when it cannot (equal to
#: ``slamq._core.WORK_BYTES_PER_CELL``, from rust/src/memory.rs).
WORK_BYTES_PER_CELL = 16

#: What :func:`evaluate` accepts: a path, an :class:`OccupancyMap`, or a numpy image array.
MapSource = Union[str, os.PathLike, OccupancyMap, Any]


def evaluate(
    source: MapSource,
    *,
    params: Params | None = None,
    curve: bool = False,
    verify: bool = False,
    threads: int | None = None,
    unknown_value: int | None = None,
    **metric_params: Any,
) -> MapQuality:
    """Compute the three map metrics of docs/spec.md sections 2-4 with the Rust core.

    Parameters
    ----------
    source : path, OccupancyMap, or numpy array
        A map file (YAML or image), an :class:`OccupancyMap`, or a 2-D uint8 image array
        (loaded with the image defaults of :func:`slamq.load_map`).
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
    unknown_value : int, optional
        Passed to :func:`slamq.load_map` when ``source`` is a path or an image array.
    {params}

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
    from slamq import _core

    params = Params.resolve(params, metric_params)
    n_threads = check_threads(threads)
    where = source if isinstance(source, (str, os.PathLike)) else getattr(
        source, "source", "<array>")
    try:
        grid = load_map(source, unknown_value=unknown_value)
    except MemoryError as exc:
        if isinstance(exc, SlamqError):
            raise
        raise OutOfMemoryError(f"{os.fspath(where)}: out of memory while loading the map"
                               ) from None
    try:
        raw = _core.evaluate(grid.values, grid.unknown, params, n_threads, grid.resolution,
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
