"""Pixel -> (values, unknown): SPEC section 1. Per-pixel work is a 256-entry table
(``cv2.LUT``): the unknown decision is computed once per pixel value with the SPEC formula
``p = (255 - v) / 255`` in float64, bounds inclusive."""

from __future__ import annotations

import functools
import logging
from typing import Any

import numpy as np

from slamq import native
from slamq.sources.files import fail
from slamq.sources.images import Image

#: map_server's defaults for optional YAML fields (ROS 1 map_server and nav2 agree).
DEFAULT_OCCUPIED_THRESH = 0.65
DEFAULT_FREE_THRESH = 0.196
DEFAULT_MODE = "trinary"
#: The grey levels ROS map_saver writes: occupied, unknown, free (+ 255, also free).
MAP_SAVER_SHADES = frozenset((0, 205, 254, 255))
MAP_SAVER_UNKNOWN = 205
#: The value held for unknown cells of OccupancyGrid data and ``raw`` maps (map_saver's
#: unknown shade, so that a plain view of ``values`` looks like a map_saver image).
GRID_UNKNOWN_SHADE = 205
MODES = ("trinary", "scale", "raw")
IDENTITY = np.arange(256, dtype=np.uint8)
NEGATE = (255 - np.arange(256)).astype(np.uint8)


def _raw_value_lut() -> np.ndarray:
    """OccupancyGrid value (as uint8: -1 -> 255) to v, SPEC 1; out of 0..100 -> 205."""
    g = np.arange(256, dtype=np.float64)
    v = np.rint(255.0 * (100.0 - g) / 100.0)
    v[101:] = GRID_UNKNOWN_SHADE
    return v.astype(np.uint8)


RAW_LUT = _raw_value_lut()


def apply_lut(img: np.ndarray, table: np.ndarray) -> np.ndarray:
    """``table[img]`` for a uint8 image and a 256-entry uint8 table (OpenCV: ~4x numpy)."""
    import cv2

    out = cv2.LUT(img, table)
    return out.reshape(img.shape)


def _map_saver_shades(grey: np.ndarray) -> tuple[list[int], np.ndarray] | None:
    """The map_saver shades present in a uint8 image and its ``== 205`` mask, or None when
    the image holds any other value.

    Most maps are map_saver images, and for them the unknown mask is exactly
    ``grey == 205``. The Rust core finds both in one pass without the GIL
    (``rust/src/pixels.rs``) without holding the GIL, which a batch's other threads would
    wait for (the numpy twin, :func:`_map_saver_shades_numpy`, holds it).

    Examples
    --------
    >>> import numpy as np
    >>> shades, unknown = _map_saver_shades(np.array([[0, 205], [254, 254]], np.uint8))
    >>> shades, unknown.tolist()
    ([0, 205, 254], [[False, True], [False, False]])
    >>> _map_saver_shades(np.array([[0, 100]], np.uint8)) is None
    True
    """
    present, unknown = native.map_saver_shades(np.ascontiguousarray(grey))
    return None if present is None else (present, unknown)


def _map_saver_shades_numpy(grey: np.ndarray) -> tuple[list[int], np.ndarray] | None:
    """:func:`_map_saver_shades` with numpy: one comparison and one count per shade of
    :data:`MAP_SAVER_SHADES` (the numpy twin the tests hold the Rust pass to)."""
    unknown = np.ascontiguousarray(grey == MAP_SAVER_UNKNOWN)
    counts = {v: int(np.count_nonzero(unknown if v == MAP_SAVER_UNKNOWN else grey == v))
              for v in MAP_SAVER_SHADES}
    if sum(counts.values()) != grey.size:
        return None
    return sorted(v for v, n in counts.items() if n), unknown


@functools.lru_cache(maxsize=64)
def _threshold_unknown_lut(negate: bool, occ: float, free: float) -> np.ndarray:
    """Unknown decision for each pixel 0..255: free <= p <= occ, p = (255 - v) / 255.
    Built once per (negate, occ, free) and read-only (a batch's maps share one)."""
    pix = np.arange(256, dtype=np.int64)
    v = 255 - pix if negate else pix
    p = (255 - v).astype(np.float64) / 255.0
    lut = (free <= p) & (p <= occ)
    lut.setflags(write=False)
    return lut


def interpret(
    img: Image,
    *,
    mode: str,
    negate: bool,
    occ: float,
    free: float,
    unknown_value: int | None,
    where: str,
    warn_disagreement: bool,
    warnings_out: list[str],
) -> tuple[np.ndarray, np.ndarray, dict[str, Any]]:
    grey = img.grey
    meta: dict[str, Any] = {}
    if mode == "raw":
        g = apply_lut(grey, NEGATE) if negate else grey
        values = apply_lut(g, RAW_LUT)
        if unknown_value is None:
            unknown = g > 100
            meta["unknown_rule"] = "raw: values outside 0..100"
        else:
            unknown = unknown_value_mask(grey, g, unknown_value, where)
            meta["unknown_rule"] = f"unknown_value={unknown_value}"
        return values, unknown, meta

    values = apply_lut(grey, NEGATE) if negate else grey
    if unknown_value is not None:
        meta["unknown_rule"] = f"unknown_value={unknown_value}"
        return values, grey == unknown_value, meta

    lut = _threshold_unknown_lut(negate, occ, free)
    shades = _map_saver_shades(grey)
    if shades is not None:
        present = np.array(shades[0], dtype=np.int64)
        rule = np.zeros(256, dtype=bool)
        rule[MAP_SAVER_UNKNOWN] = True
        differ = present[lut[present] != rule[present]]
        if warn_disagreement and differ.size:
            listed = ", ".join(str(int(x)) for x in differ)
            message = (
                f"{where}: the YAML thresholds (occupied_thresh {occ}, free_thresh {free}"
                f"{', negate 1' if negate else ''}) would classify map_saver shade(s) "
                f"{listed} differently; using the map_saver rule (205 unknown, 0/254/255 known)"
            )
            if differ.tolist() == [MAP_SAVER_UNKNOWN] and not negate and free > DEFAULT_FREE_THRESH:
                # nav2 / slam_toolbox write free_thresh 0.25 with 205 as unknown: their own
                # convention, handled as they mean it; a note, not a warning
                logging.getLogger("slamq").debug("%s", message)
            else:
                warnings_out.append(message)
        unknown = shades[1]
        meta["unknown_rule"] = "map_saver: 205 unknown, 0/254/255 known"
    else:
        meta["unknown_rule"] = f"thresholds: {free} <= p <= {occ}"
        unknown = apply_lut(grey, lut.astype(np.uint8)).view(bool)
    if mode == "scale" and img.alpha is not None:
        unknown |= img.alpha < 255
        meta["unknown_rule"] += "; alpha < 255"
    return values, unknown, meta


def unknown_value_mask(
    pixels: np.ndarray, grid_values: np.ndarray, n: int, where: str
) -> np.ndarray:
    """``pixels == n`` for raw data; refuse to call out-of-range grid values known."""
    unknown = pixels == n
    bad = (grid_values > 100) & ~unknown
    if bad.any():
        first = int(grid_values[bad].flat[0])
        signed = first - 256 if first > 127 else first
        raise fail(where, f"unknown_value={n} leaves cells with OccupancyGrid value "
                           f"{signed} (outside 0..100) known, but they have no occupancy")
    return unknown
