"""What a map format's reader gives (:class:`RawMap`) and the one step that turns it into an
:class:`~slamq.models.OccupancyMap` (:func:`interpret`, docs/spec.md section 1).

A reader either hands over *pixels* and the rule that reads them (map_server's mode,
negate and thresholds: YAML maps, bare images, MRPT grids) or *cells* it has already
decoded from OccupancyGrid data (bags, Cartographer submaps), whose values and unknown
mask follow section 1's OccupancyGrid rule. :func:`interpret` applies the rule, then the
caller's ``unknown_value`` / resolution / origin.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from slamq.errors import MapError
from slamq.models import OccupancyMap
from slamq.sources.files import check_unknown_value
from slamq.sources.images import Image
from slamq.sources.pixels import (
    DEFAULT_FREE_THRESH,
    DEFAULT_MODE,
    DEFAULT_OCCUPIED_THRESH,
    NEGATE,
    apply_lut,
    unknown_value_mask,
)
from slamq.sources.pixels import (
    interpret as interpret_pixels,
)

__all__ = ["RawMap", "interpret", "reapply"]


@dataclasses.dataclass
class RawMap:
    """A map as its format stores it, before section 1's rule made cells of it.

    Exactly one of ``image`` (pixels) and ``grid`` (cells already interpreted) is set.

    Attributes
    ----------
    source : str
        What the map is called in messages and ``OccupancyMap.source``.
    image : Image, optional
        The decoded pixels (grey level, alpha, channel count, file format).
    grid : OccupancyMap, optional
        Cells a reader decoded from OccupancyGrid data.
    mode, negate, occupied_thresh, free_thresh
        map_server's rule for ``image`` (its defaults for a bare image).
    resolution : float, optional
        Metres per cell as the file says (None: the file does not say).
    origin : (x, y, yaw)
    meta : dict
        What the reader knows besides (``kind``, ``yaml``, ``image``, ``resolution_from``,
        ...); ``interpret`` adds the rule's own entries.
    warnings : list of (str, str)
        The reader's messages (issued as :class:`~slamq.errors.MapWarning` by ``load_map``),
        each with the field (``"resolution"``, ``"origin"``) whose override makes it moot,
        or ``""``.
    errors : dict
        Field -> :class:`~slamq.errors.MapError` for a value of the file that cannot be
        used; raised unless the caller overrides that field.
    warn_disagreement : bool
        Warn when the thresholds read map_saver shades otherwise than the shade rule (a YAML
        that states thresholds; never a bare image, whose thresholds nobody wrote).
    """

    source: str
    image: Image | None = None
    grid: OccupancyMap | None = None
    mode: str = DEFAULT_MODE
    negate: bool = False
    occupied_thresh: float = DEFAULT_OCCUPIED_THRESH
    free_thresh: float = DEFAULT_FREE_THRESH
    resolution: float | None = None
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    meta: dict[str, Any] = dataclasses.field(default_factory=dict)
    warnings: list[tuple[str, str]] = dataclasses.field(default_factory=list)
    errors: dict[str, MapError] = dataclasses.field(default_factory=dict)
    warn_disagreement: bool = False


def interpret(
    raw: RawMap,
    *,
    unknown_value: int | None = None,
    resolution: float | None = None,
    origin: tuple[float, float, float] | None = None,
    warnings_out: list[str] | None = None,
) -> OccupancyMap:
    """Turn what a reader gave into cells (docs/spec.md section 1).

    Parameters
    ----------
    raw : RawMap
    unknown_value : int, optional
        Pixel (or OccupancyGrid value) that alone means unknown; checked against the mode.
    resolution, origin : optional
        Override what the file says (already checked by the caller).
    warnings_out : list of str, optional
        Receives the reader's and the rule's messages, in that order.

    Examples
    --------
    >>> import numpy as np
    >>> from slamq.sources.images import Image
    >>> px = np.array([[0, 205], [254, 100]], np.uint8)
    >>> m = interpret(RawMap("m.pgm", image=Image(px, None, 1)), resolution=0.05)
    >>> m.unknown.tolist(), m.meta["unknown_rule"], m.resolution
    ([[False, True], [False, True]], 'thresholds: 0.196 <= p <= 0.65', 0.05)
    """
    out = [] if warnings_out is None else warnings_out
    overridden = {"resolution": resolution is not None, "origin": origin is not None}
    for field, error in raw.errors.items():
        if not overridden.get(field):
            raise error
    out.extend(msg for field, msg in raw.warnings if not overridden.get(field))
    if raw.grid is not None:
        return reapply(raw.grid, unknown_value, resolution, origin)
    assert raw.image is not None, "a RawMap holds pixels or a grid"
    img = raw.image
    n = None if unknown_value is None else check_unknown_value(
        unknown_value, raw.source, grid=raw.mode == "raw")
    values, unknown, rule = interpret_pixels(
        img, mode=raw.mode, negate=raw.negate, occ=raw.occupied_thresh,
        free=raw.free_thresh, unknown_value=n, where=raw.source,
        warn_disagreement=raw.warn_disagreement, warnings_out=out,
    )
    meta = dict(raw.meta)
    res = raw.resolution
    if resolution is not None:
        res = resolution
        meta["resolution_from"] = "argument"
    meta = {
        "kind": meta.pop("kind", "image"),
        "mode": raw.mode,
        "negate": raw.negate,
        "occupied_thresh": raw.occupied_thresh,
        "free_thresh": raw.free_thresh,
        "yaml": meta.pop("yaml", None),
        "image": meta.pop("image", None),
        "format": img.format,
        "channels": img.channels,
        "resolution_from": meta.pop("resolution_from", None),
        "warnings": list(out),
        "pixels": img.grey,
        **rule,
        **meta,
    }
    return OccupancyMap(values, unknown, res, raw.origin if origin is None else origin,
                        raw.source, meta)


def reapply(
    m: OccupancyMap,
    unknown_value: int | None,
    resolution: float | None,
    origin: tuple[float, float, float] | None,
) -> OccupancyMap:
    """An OccupancyMap with ``unknown_value`` / resolution / origin re-applied.

    Examples
    --------
    >>> import numpy as np
    >>> m = OccupancyMap(np.array([[0, 255]], np.uint8), np.zeros((1, 2), bool), 0.05,
    ...                  (0.0, 0.0, 0.0), "m")
    >>> reapply(m, 255, None, None).unknown.tolist()
    [[False, True]]
    """
    if unknown_value is None and resolution is None and origin is None:
        return m
    meta = dict(m.meta)
    unknown = m.unknown
    if unknown_value is not None:
        grid = meta.get("mode") == "raw"
        n = check_unknown_value(unknown_value, m.source, grid=grid)
        pixels = meta.get("pixels")
        if not isinstance(pixels, np.ndarray) or pixels.shape != m.values.shape:
            pixels = m.values  # a hand-built map: its values are its pixels
        if grid:
            g = apply_lut(pixels, NEGATE) if meta.get("negate") else pixels
            unknown = unknown_value_mask(pixels, g, n, m.source)
        else:
            unknown = pixels == n
        meta["unknown_rule"] = f"unknown_value={n}"
    if resolution is not None:
        meta["resolution_from"] = "argument"
    return OccupancyMap(
        m.values,
        unknown,
        m.resolution if resolution is None else resolution,
        m.origin if origin is None else origin,
        m.source,
        meta,
    )
