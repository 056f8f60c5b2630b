"""``slamq.evaluate``: the three map metrics of SPEC.md sections 2-4, computed by the Rust core.

Follow one map from here: :func:`evaluate` loads it (:func:`slamq.load_map`), hands the
``values`` and ``unknown`` buffers to ``slamq._core.evaluate`` (rust/src/python.rs, which
calls proportion.rs, corners.rs and enclosed.rs) and wraps the integers it returns in a
:class:`MapQuality`. Ratios are computed here, from those integers, by the same Python
expressions :mod:`slamq.reference` uses, so both sides agree bit for bit.
"""

from __future__ import annotations

import math
import numbers
import os
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from typing import Any, Union

from slamq.errors import ConformanceError
from slamq.maps import OccupancyMap, load_map
from slamq.params import Params

__all__ = ["MapQuality", "evaluate"]

#: What :func:`evaluate` accepts: a path, an :class:`OccupancyMap`, or a numpy image array.
MapSource = Union[str, os.PathLike, OccupancyMap, Any]


@dataclass(frozen=True)
class MapQuality:
    """The three metrics of one map (SPEC.md sections 2-4) and the parameters used.

    Attributes
    ----------
    source : str
        The map's path, or ``"<array>"``.
    height, width : int
        Map size in cells.
    total, known, unknown, occupied, free : int
        Cell counts. ``free = known - occupied``; ``total = known + unknown``.
    occupied_fraction : float
        ``occupied / known`` (NaN when no cell is known): the canvas-independent figure.
    proportion : float
        ``occupied / (free + unknown)``: the paper's Fig. 5 ratio (canvas dependent).
    threshold : float
        Mean occupancy probability of the known cells, ``sum(255 - v) / (255 * known)``.
    corners : int
        Corner count (LoG structure mask + Harris), SPEC section 3.
    enclosed_areas : int
        Largest number of enclosed free regions over the unknown-value sweep, SPEC section 4.
    enclosed_unknown_value : int
        The smallest unknown value ``u`` reaching ``enclosed_areas``.
    curve : tuple of int or None
        ``count_u`` for every ``u`` in ``params.sweep_values`` (when asked for).
    params : Params
        The parameters used.

    Examples
    --------
    >>> import numpy as np
    >>> import slamq
    >>> room = np.full((7, 7), 205, np.uint8)
    >>> room[1:6, 1:6] = 0
    >>> room[2:5, 2:5] = 254
    >>> q = slamq.evaluate(slamq.OccupancyMap(room, room == 205))
    >>> q.enclosed_areas, q.occupied, q.free
    (1, 16, 9)
    """

    source: str
    height: int
    width: int
    total: int
    known: int
    unknown: int
    occupied: int
    free: int
    occupied_fraction: float
    proportion: float
    threshold: float
    corners: int
    enclosed_areas: int
    enclosed_unknown_value: int
    curve: tuple[int, ...] | None = None
    params: Params = field(default_factory=Params)

    @classmethod
    def from_counts(
        cls,
        *,
        source: str,
        shape: tuple[int, int],
        known: int,
        occupied: int,
        sum_darkness: int,
        corners: int,
        curve: Sequence[int],
        params: Params,
        keep_curve: bool,
    ) -> MapQuality:
        """Build the result from the integers both implementations produce.

        ``curve`` holds ``count_u`` for every ``u`` in ``params.sweep_values``.
        """
        height, width = int(shape[0]), int(shape[1])
        total = height * width
        known = int(known)
        occupied = int(occupied)
        unknown = total - known
        free = known - occupied
        nan = math.nan
        occupied_fraction = occupied / known if known else nan
        denominator = free + unknown
        proportion = (occupied / denominator if denominator else nan) if known else nan
        threshold = int(sum_darkness) / (255 * known) if known else nan
        counts = tuple(int(c) for c in curve)
        best = max(counts) if counts else 0
        best_u = params.sweep_values[counts.index(best)] if counts else 0
        return cls(
            source=source,
            height=height,
            width=width,
            total=total,
            known=known,
            unknown=unknown,
            occupied=occupied,
            free=free,
            occupied_fraction=occupied_fraction,
            proportion=proportion,
            threshold=threshold,
            corners=int(corners),
            enclosed_areas=best,
            enclosed_unknown_value=int(best_u),
            curve=counts if keep_curve else None,
            params=params,
        )

    def to_dict(self) -> dict[str, Any]:
        """A flat, JSON-ready dict: every field, the curve as a list, params inlined.

        Examples
        --------
        >>> import numpy as np, slamq
        >>> d = slamq.evaluate(np.full((3, 3), 254, np.uint8)).to_dict()
        >>> d["corners"], d["param_sweep_step"]
        (0, 1)
        """
        out = asdict(self)
        params = out.pop("params")
        if out["curve"] is not None:
            out["curve"] = list(out["curve"])
        out.update({f"param_{k}": v for k, v in params.items()})
        return out

    def differences(self, other: MapQuality, rel: float = 1e-12) -> list[str]:
        """Fields on which two results disagree (integers exactly, ratios to ``rel``).

        Examples
        --------
        >>> import numpy as np, slamq
        >>> q = slamq.evaluate(np.zeros((4, 4), np.uint8))
        >>> q.differences(q)
        []
        """
        diffs = []
        for name in (
            "height", "width", "total", "known", "unknown", "occupied", "free",
            "corners", "enclosed_areas", "enclosed_unknown_value", "curve",
        ):
            a, b = getattr(self, name), getattr(other, name)
            if a != b and not (name == "curve" and (a is None or b is None)):
                diffs.append(f"{name}: {a!r} != {b!r}")
        for name in ("occupied_fraction", "proportion", "threshold"):
            a, b = getattr(self, name), getattr(other, name)
            if math.isnan(a) and math.isnan(b):
                continue
            if not math.isclose(a, b, rel_tol=rel, abs_tol=0.0):
                diffs.append(f"{name}: {a!r} != {b!r}")
        return diffs


def evaluate(
    source: MapSource,
    *,
    log_threshold: float = 0.1,
    min_dot_area: int = 5,
    harris_k: float = 0.04,
    harris_quality: float = 0.01,
    sweep_step: int = 1,
    min_area: int = 1,
    curve: bool = False,
    verify: bool = False,
    threads: int | None = None,
    unknown_value: int | None = None,
) -> MapQuality:
    """Compute the three map metrics of SPEC.md sections 2-4 with the Rust core.

    Parameters
    ----------
    source : path, OccupancyMap, or numpy array
        A map file (YAML or image), an :class:`OccupancyMap`, or a 2-D uint8 image array
        (loaded with the image defaults of :func:`slamq.load_map`).
    log_threshold, min_dot_area, harris_k, harris_quality, sweep_step, min_area
        The metric parameters; see :class:`slamq.Params` for meaning, units and ranges.
    curve : bool, default False
        Keep the whole enclosed-area curve ``count_u`` in the result.
    verify : bool, default False
        Also run :mod:`slamq.reference` and raise :class:`slamq.ConformanceError` on any
        difference (slow: the reference labels the map once per sweep value).
    threads : int, optional
        Cap on the Rust worker threads for this call (default: all cores). Results do not
        depend on it.
    unknown_value : int, optional
        Passed to :func:`slamq.load_map` when ``source`` is a path or an image array.

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
    """
    from slamq import _core

    params = Params(
        log_threshold=log_threshold,
        min_dot_area=min_dot_area,
        harris_k=harris_k,
        harris_quality=harris_quality,
        sweep_step=sweep_step,
        min_area=min_area,
    )
    if threads is not None and (isinstance(threads, bool) or not isinstance(
            threads, numbers.Integral) or threads < 1):
        from slamq.errors import ParamError

        raise ParamError(f"threads must be a positive integer, got {threads!r}")
    grid = load_map(source, unknown_value=unknown_value)
    raw = _core.evaluate(
        grid.values,
        grid.unknown,
        params.log_threshold,
        params.min_dot_area,
        params.harris_k,
        params.harris_quality,
        params.sweep_step,
        params.min_area,
        0 if threads is None else int(threads),
    )
    result = MapQuality.from_counts(
        source=grid.source,
        shape=grid.shape,
        known=raw["known"],
        occupied=raw["occupied"],
        sum_darkness=raw["sum_darkness"],
        corners=raw["corners"],
        curve=raw["curve"],
        params=params,
        keep_curve=curve or verify,
    )
    if verify:
        from slamq import reference

        expected = reference.evaluate(grid, curve=True, **params.to_dict())
        diffs = result.differences(expected)
        if diffs:
            raise ConformanceError(
                f"{grid.source}: Rust core and slamq.reference disagree: " + "; ".join(diffs)
            )
        if not curve:
            result = _without_curve(result)
    return result


def _without_curve(result: MapQuality) -> MapQuality:
    from dataclasses import replace

    return replace(result, curve=None)
