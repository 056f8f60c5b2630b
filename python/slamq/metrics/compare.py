"""A map against a ground-truth map (docs/spec.md section 7), by the Rust core
(``slamq.compare`` is this after :mod:`slamq.api` has loaded both maps).

Follow one pair from here: :func:`compare` hands the two maps' buffers and frames to
:func:`slamq.native.compare` (rust/src/bindings/comparison.rs ->
compare/, which uses edt/ for the distance transforms and icp.rs for the alignment) and
wraps the counts it returns in a :class:`~slamq.MapComparison`.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import replace
from typing import Any

from slamq import native
from slamq.errors import MapError, ParamError
from slamq.models import MapComparison, OccupancyMap
from slamq.params import SETTINGS, check_threads

__all__ = ["ALIGN_MODES", "DEFAULT_TOLERANCE_CELLS", "MIN_FIT_PRECISION", "compare",
           "poor_fit"]

#: The alignments :func:`compare` knows (the schema's ``compare_align`` choices).
ALIGN_MODES = SETTINGS.compare_align.choices
#: The default matching distance, in cells of the ground truth's grid.
DEFAULT_TOLERANCE_CELLS = SETTINGS.tolerance_cells.default
#: Under this precision an alignment fits poorly (docs/spec.md section 7, "Fit").
MIN_FIT_PRECISION = SETTINGS.min_fit_precision.default


def _number(name: str, value: Any, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ParamError(f"{name} must be a number, got {value!r}")
    x = float(value)
    if not math.isfinite(x) or x < 0 or (positive and x == 0):
        raise ParamError(f"{name} must be a finite number {'>' if positive else '>='} 0, "
                         f"got {value!r}")
    return x


def _frame(m: OccupancyMap, resolution: float) -> tuple[float, float, float, float]:
    x, y, yaw = m.origin
    return (resolution, x, y, yaw)


def compare(
    estimate: OccupancyMap,
    ground_truth: OccupancyMap,
    *,
    tolerance: float | None = None,
    occupied_threshold: float = SETTINGS.occupied_threshold.default,
    align: str = SETTINGS.compare_align.default,
    max_distance: float | None = None,
    cells: bool = False,
    threads: int | None = None,
    min_fit_precision: float = MIN_FIT_PRECISION,
    cells_box: tuple[int, int, int, int] | None = None,
) -> MapComparison:
    """Score a map against a ground-truth map, aligned (docs/spec.md section 7).

    The estimate is placed by the frames the two maps give (resolution, origin), refined by
    a trimmed SE(2) ICP of its occupied cells onto the ground truth's (``align``), and
    resampled onto the ground truth's grid; the figures are computed there.

    Parameters
    ----------
    estimate, ground_truth : OccupancyMap
        The two maps (:func:`slamq.compare` takes paths and image arrays too). A map without
        a resolution (from a bare array) takes the other map's, or 1 (distances then count
        cells).
    tolerance : float, optional
        Matching distance for precision and recall, metres (default: 2 cells of the ground
        truth's resolution).
    occupied_threshold : float, default 0.5
        A known cell is occupied when its occupancy probability ``(255 - v) / 255`` is above
        this (0.5: values below 128).
    align : {"icp", "origin", "search", "auto"}, default "icp"
        ``origin``: the maps' frames only. ``icp``: refined by trimmed ICP. ``search``: the ICP
        starts from the global registration (:func:`slamq.register`, docs/spec.md 7a),
        for maps saved in an arbitrary frame. ``auto``: ``icp``, and when that fits poorly
        (precision under ``min_fit_precision``) also ``search``, keeping the one with the
        higher precision; ``MapComparison.align`` says which was used and ``note`` why.
        With ``icp`` or ``origin`` a poor fit is kept, and ``note`` says what ``search``
        gives.
    max_distance : float, optional
        Distances above this many metres count as ``max_distance`` (``truncated`` says how
        many), so that a half-built map's ``ne`` stays bounded.
    cells : bool, default False
        Keep the per-cell flags (for overlays) in ``MapComparison.cells``.
    threads : int, optional
        Cap on the Rust worker threads (default: all cores). Results do not depend on it.
    min_fit_precision : float, default 0.5
        An alignment whose precision is under this fits poorly: ``search`` is tried too
        and ``MapComparison.note`` says what it gives (:func:`slamq.compare` warns).
    cells_box : tuple of int, optional
        With ``cells``: keep the flags of the box ``(row0, row1, col0, col1)`` of the
        ground truth's grid only (ends exclusive, clipped to the grid), which is faster
        than the whole grid's; the figures are the whole grid's all the same.

    Returns
    -------
    MapComparison

    Raises
    ------
    slamq.MapError
        Two maps that cannot be compared (naming both).
    slamq.ParamError
        A parameter out of range.

    Examples
    --------
    >>> import numpy as np
    >>> from slamq.models import OccupancyMap
    >>> walls = np.full((40, 40), 254, np.uint8)
    >>> walls[10, 5:35] = 0; walls[10:30, 5] = 0         # two walls: the ground truth
    >>> half = walls.copy(); half[10:30, 5] = 254         # the estimate lacks one
    >>> none = np.zeros(walls.shape, bool)                # no unknown cell
    >>> c = compare(OccupancyMap(half, none), OccupancyMap(walls, none), align="origin")
    >>> round(c.recall, 3), c.reverse, c.ne > 0
    (0.633, 0.0, True)
    """
    for what, m in (("estimate", estimate), ("ground_truth", ground_truth)):
        if not isinstance(m, OccupancyMap):
            raise ParamError(f"compare takes OccupancyMaps, not {type(m).__name__} as {what};"
                             " slamq.compare reads files and arrays")
    if align not in ALIGN_MODES:
        raise ParamError(f"align must be one of {', '.join(ALIGN_MODES)}, got {align!r}")
    threshold = _number("occupied_threshold", occupied_threshold)
    if threshold >= 1:
        raise ParamError(f"occupied_threshold must be in [0, 1), got {occupied_threshold!r}")
    n_threads = check_threads(threads)
    fit = _number("min_fit_precision", min_fit_precision)
    if fit > 1:
        raise ParamError(f"min_fit_precision must be in [0, 1], got {min_fit_precision!r}")
    est, gt = estimate, ground_truth
    res_gt = gt.resolution or est.resolution or 1.0
    res_est = est.resolution or gt.resolution or 1.0
    tol = (DEFAULT_TOLERANCE_CELLS * res_gt if tolerance is None
           else _number("tolerance", tolerance))
    cap = None if max_distance is None else _number("max_distance", max_distance, True)
    box = {}
    if cells_box is not None:
        if not (isinstance(cells_box, tuple) and len(cells_box) == 4 and all(
                isinstance(v, numbers.Integral) and not isinstance(v, bool) and v >= 0
                for v in cells_box)):
            raise ParamError(f"cells_box must be 4 integers >= 0 (row0, row1, col0, col1), "
                             f"got {cells_box!r}")
        box = {"cells_box": tuple(int(v) for v in cells_box)}

    def aligned(mode: str) -> MapComparison:
        try:
            raw, flags = native.compare(
                est.values, est.unknown, _frame(est, res_est),
                gt.values, gt.unknown, _frame(gt, res_gt),
                tolerance=tol / res_gt, occupied_threshold=threshold, align=mode,
                max_distance=None if cap is None else cap / res_gt, cells=cells,
                threads=n_threads, **box,
            )
        except ValueError as exc:
            raise MapError(f"{est.source} vs {gt.source}: {exc}") from None
        return MapComparison.from_counts(
            raw, estimate=est.source, ground_truth=gt.source, resolution=res_gt,
            tolerance=tol, max_distance=cap, align=mode, occupied_threshold=threshold,
            cells=flags,
        )

    first = aligned("icp" if align == "auto" else align)
    if align == "search" or not poor_fit(first, fit):
        return first
    second = aligned("search")
    if align == "auto" and second.precision > first.precision:
        still = "; it still fits poorly: the map may be broken or of another place" \
            if poor_fit(second, fit) else ""
        return replace(second, note=f"icp fitted poorly ({_fit_text(first)}); aligned by the "
                       f"global registration (search: {_fit_text(second)}){still}")
    if second.precision > first.precision and not poor_fit(second, fit):
        return replace(first, note=f"{align} fits poorly ({_fit_text(first)}); the global "
                       f"registration fits better (search: {_fit_text(second)}): the maps' "
                       "frames may differ")
    return replace(first, note=f"{first.align} fits poorly ({_fit_text(first)}) and the global "
                   f"registration no better (search: {_fit_text(second)}): the map may be "
                   "broken or of another place")


def poor_fit(c: MapComparison, min_fit_precision: float = MIN_FIT_PRECISION) -> bool:
    """Whether an alignment fits poorly: its precision is under ``min_fit_precision``.

    Precision is the share of the estimate's walls within the tolerance of a ground-truth
    wall once aligned; a partial map keeps it high, a map in another frame does not. An
    estimate without walls (NaN precision) is not a poor fit but an empty map.

    Examples
    --------
    >>> import numpy as np, slamq
    >>> img = np.full((30, 30), 254, np.uint8); img[5, 5:25] = 0
    >>> poor_fit(slamq.compare(img, img))
    False
    """
    return c.precision < min_fit_precision


def _fit_text(c: MapComparison) -> str:
    rms = "" if math.isnan(c.icp_rms) else f", ICP RMS {c.icp_rms:.3g} m"
    return f"precision {c.precision:.3f}, F1 {c.f1:.3f}{rms}"
