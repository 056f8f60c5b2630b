"""nav_msgs/OccupancyGrid data (row 0 = bottom) as an :class:`~slamq.models.OccupancyMap`
held north up (SPEC section 1)."""

from __future__ import annotations

from typing import Any

import numpy as np

from slamq.models import OccupancyMap
from slamq.sources.files import check_origin, check_resolution, fail
from slamq.sources.pixels import RAW_LUT, apply_lut


def from_occupancy_grid(
    data: Any,
    *,
    width: int | None = None,
    height: int | None = None,
    resolution: float | None,
    origin: Any = (0.0, 0.0, 0.0),
    source: str = "<OccupancyGrid>",
) -> OccupancyMap:
    """Build a map from nav_msgs/OccupancyGrid data (row 0 = bottom), flipped north up.

    Values -1 (and anything outside 0..100) are unknown; a known value g becomes
    ``v = rint(255 * (100 - g) / 100)`` (half to even), SPEC section 1. Unknown cells hold
    205 in ``values`` (map_saver's unknown shade).

    Parameters
    ----------
    data : array-like of int8 (or integers in -128..127)
        ``(height, width)``, or flat of length ``width * height`` in message order.
    width, height : int, optional
        Needed when ``data`` is flat; checked when it is 2-D.
    resolution : float or None
        Metres per cell (``info.resolution``).
    origin : (x, y, yaw)
        Pose of the lower-left cell (``info.origin``, yaw from its quaternion).
    source : str
        Named in errors and kept as ``OccupancyMap.source``.

    Returns
    -------
    OccupancyMap

    Examples
    --------
    >>> import numpy as np
    >>> from slamq.sources import from_occupancy_grid
    >>> m = from_occupancy_grid(np.array([0, 100, -1, 50], np.int8), width=2, height=2,
    ...                         resolution=0.05)
    >>> m.values.tolist(), m.unknown.tolist()   # row 0 of the message is the bottom
    ([[205, 128], [255, 0]], [[True, False], [False, False]])
    """
    res = check_resolution(resolution, source)
    org = check_origin(origin, source)
    arr = np.asarray(data)
    if arr.dtype != np.int8:
        if arr.dtype.kind not in "iu" or arr.dtype == np.bool_:
            raise fail(source, f"OccupancyGrid data must be int8, got {arr.dtype}")
        if arr.size and (arr.min() < -128 or arr.max() > 127):
            raise fail(source, "OccupancyGrid data must be in -128..127 (int8)")
        arr = arr.astype(np.int8)
    for what, val in (("width", width), ("height", height)):
        if val is not None and (isinstance(val, bool) or not isinstance(val, (int, np.integer))
                                or val < 0):
            raise fail(source, f"{what} must be a non-negative integer, got {val!r}")
    if arr.ndim == 1:
        if width is None or height is None:
            raise fail(source, "flat OccupancyGrid data needs width and height")
        if arr.size != int(width) * int(height):
            raise fail(source, f"OccupancyGrid data has {arr.size} cells, but width x height "
                                f"= {width} x {height} = {int(width) * int(height)}")
        arr = arr.reshape(int(height), int(width))
    elif arr.ndim == 2:
        if (width is not None and arr.shape[1] != width) or (
            height is not None and arr.shape[0] != height
        ):
            raise fail(source, f"OccupancyGrid data shape {arr.shape} != "
                                f"(height, width) = ({height}, {width})")
    else:
        raise fail(source, f"OccupancyGrid data must be 1-D or 2-D, got {arr.ndim}-D")
    if arr.size == 0:
        raise fail(source, "the map has zero cells")
    pixels = np.ascontiguousarray(arr[::-1]).view(np.uint8)
    meta = {
        "kind": "occupancy_grid",
        "mode": "raw",
        "negate": False,
        "occupied_thresh": None,
        "free_thresh": None,
        "yaml": None,
        "image": None,
        "format": "OccupancyGrid",
        "channels": 1,
        "resolution_from": None if res is None else "argument",
        "warnings": [],
        "pixels": pixels,
        "unknown_rule": "OccupancyGrid: values outside 0..100",
    }
    return OccupancyMap(apply_lut(pixels, RAW_LUT), pixels > 100, res, org, source, meta)
