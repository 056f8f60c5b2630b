"""``OccupancyMap``: an occupancy grid held image-style (row 0 at the top, north up), as
SPEC section 1 defines it. Plain data: the readers that build it live in :mod:`slamq.sources`."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from slamq.errors import MapError

__all__ = ["OccupancyMap"]


@dataclass(frozen=True, eq=False)
class OccupancyMap:
    """An occupancy grid held image-style (row 0 = top = north).

    Attributes
    ----------
    values : numpy.ndarray
        ``(H, W)`` uint8, C-contiguous. 0 = surely occupied, 255 = surely free. The value
        of an unknown cell is whatever the file held; the metrics ignore it.
    unknown : numpy.ndarray
        ``(H, W)`` bool, C-contiguous; True where the cell is unknown.
    resolution : float or None
        Metres per cell (None for a bare image without metadata).
    origin : tuple of float
        ``(x, y, yaw)`` of the lower-left cell, ROS convention.
    source : str
        Where the map came from: a file path, or ``"<array>"``.
    meta : dict
        Loader details (mode, thresholds, negate, image path, warnings).

    Examples
    --------
    >>> import numpy as np
    >>> from slamq import OccupancyMap
    >>> m = OccupancyMap(np.full((2, 3), 254, np.uint8), np.zeros((2, 3), bool))
    >>> m.shape, m.known_count
    ((2, 3), 6)
    >>> m
    OccupancyMap('<array>', 2x3 cells, 6 known, resolution=None, origin=(0, 0, 0))
    """

    values: np.ndarray
    unknown: np.ndarray
    resolution: float | None = None
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    source: str = "<array>"
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        values = np.asarray(self.values)
        unknown = np.asarray(self.unknown)
        if values.ndim != 2 or values.dtype != np.uint8:
            raise MapError(
                f"{self.source}: values must be a 2-D uint8 array, "
                f"got {values.ndim}-D {values.dtype}"
            )
        if unknown.shape != values.shape:
            raise MapError(
                f"{self.source}: unknown mask shape {unknown.shape} != values shape {values.shape}"
            )
        if values.size == 0:
            raise MapError(f"{self.source}: the map has zero cells")
        if self.resolution is not None:
            res = _finite(self.resolution, "resolution", self.source)
            if not res > 0.0:
                raise MapError(f"{self.source}: resolution must be > 0, got {res}")
            object.__setattr__(self, "resolution", res)
        origin = self.origin
        if isinstance(origin, (str, bytes)) or not hasattr(origin, "__len__") or len(
                origin) != 3:
            raise MapError(f"{self.source}: origin must be (x, y, yaw), got "
                           f"{str(origin)[:80]!r}")
        object.__setattr__(self, "origin", tuple(
            _finite(x, "origin", self.source) for x in origin))
        if unknown.dtype == np.bool_:
            # a bool array's bytes may be other than 0/1 (uint8.view(bool)); the core reads
            # them as bytes, so normalise: one pass over the mask, no copy when clean
            if unknown.size and unknown.view(np.uint8).max() > 1:
                unknown = unknown.view(np.uint8) != 0
        object.__setattr__(self, "values", np.ascontiguousarray(values))
        object.__setattr__(self, "unknown", np.ascontiguousarray(unknown, dtype=bool))

    def __repr__(self) -> str:
        res = "None" if self.resolution is None else f"{self.resolution:g}"
        origin = ", ".join(f"{x:g}" for x in self.origin)
        return (f"OccupancyMap({self.source!r}, {self.shape[0]}x{self.shape[1]} cells, "
                f"{self.known_count} known, resolution={res}, origin=({origin}))")

    @property
    def shape(self) -> tuple[int, int]:
        """``(H, W)`` in cells."""
        return (int(self.values.shape[0]), int(self.values.shape[1]))

    @property
    def known_count(self) -> int:
        """Number of known cells."""
        return int(self.unknown.size - np.count_nonzero(self.unknown))


def _finite(value: Any, what: str, source: str) -> float:
    """``value`` as a finite float, or a MapError naming the map."""
    try:
        number = float(value)
    except (TypeError, ValueError, OverflowError):
        raise MapError(f"{source}: {what} must be a number, got {str(value)[:80]!r}") from None
    if not math.isfinite(number):
        raise MapError(f"{source}: {what} must be finite, got {number}")
    return number
