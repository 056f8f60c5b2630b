"""Loading occupancy grids: files of every registered map format
(:mod:`slamq.sources.formats`), images and OccupancyGrid arrays, and OccupancyMaps.

docs/spec.md section 1 is the contract. Every map is held image-style (row 0 at the top,
north up) as ``values`` (uint8, 0 = surely occupied, 255 = surely free) plus an
``unknown`` mask.

Choices the SPEC leaves open, made here:

* The *pixel* is the file's grey level (RGB/RGBA: ``rint`` of the mean of the colour
  channels), before ``negate``. The map_saver shade rule looks at pixels (all in
  {0, 205, 254, 255} -> 205 unknown) in ``trinary`` and ``scale`` modes, with or without
  ``negate``; ``unknown_value`` compares pixels too. ``scale`` still makes alpha < 255
  unknown under the shade rule.
* ``raw`` applies ``negate`` first, like ROS map_server. Unknown cells of ``raw`` maps and
  OccupancyGrid data hold 205 in ``values``; ``unknown_value`` that would make an
  out-of-range grid value known is refused (it has no occupancy).
* PGM/PPM with maxval < 255 are scaled as SDL_image (map_server's reader) does:
  ``x * 255 // maxval``. 16-bit and float images are refused.
* Decoding never allocates more than the file can hold: PGM sizes are checked against the
  file length, PNG sizes against zlib's best ratio, JPEG sizes against one bit per 8x8
  block, before any pixel buffer exists. Only regular files are read (never a FIFO).
* Per-pixel work is a 256-entry table (``cv2.LUT``): the unknown decision is computed once
  per pixel value with the SPEC formula ``p = (255 - v) / 255`` in float64, bounds inclusive.
"""

from __future__ import annotations

import functools
import os
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from slamq.errors import MapError, MapWarning
from slamq.models import OccupancyMap
from slamq.sources.files import (
    MAX_IMAGE_BYTES,
    YAML_SUFFIXES,
    check_origin,
    check_resolution,
    check_unknown_value,
    fail,
    stat_path,
)
from slamq.sources.formats import format_of, get_format, read_raw
from slamq.sources.formats.image import raw_image
from slamq.sources.formats.map_server import image_of
from slamq.sources.formats.raw import interpret, reapply
from slamq.sources.images import Image, decode_image, read_image_file, split_channels


def load_map(
    source: Any,
    *,
    unknown_value: int | None = None,
    resolution: float | None = None,
    origin: Any = None,
    topic: str | None = None,
) -> OccupancyMap:
    """Load an occupancy grid from a file, an array or a bag, per docs/spec.md section 1.

    Parameters
    ----------
    source : str, os.PathLike, numpy.ndarray or OccupancyMap
        * a ROS map_server YAML (``.yaml``/``.yml``) and the image it names (PGM, PNG or
          anything OpenCV reads; grey, RGB or RGBA; modes ``trinary``, ``scale``, ``raw``;
          ``negate``). An absolute ``image:`` path that does not exist falls back to the
          file of that name beside the YAML, with a :class:`~slamq.errors.MapWarning`.
        * a bare image: map_server's defaults (trinary, 0.65 / 0.196, no negate); the
          resolution comes from a PGM comment like ``# CREATOR: map_saver.cpp 0.050 m/pix``
          when there is one.
        * a ROS bag (``.bag``, ``.mcap``, ``.db3``, or a folder holding ``metadata.yaml``):
          the last map on ``/map``, via ``slamq.sources.bag_maps.read_last_map``.
        * a Cartographer ``.pbstream``: its 2D submaps rasterised, via
          ``slamq.sources.pbstream_map.read_pbstream_map``.
        * an MRPT grid: a PNG with its ``<stem>_limits.txt`` beside it (resolution and
          origin from the limits, map_server's default thresholds).
        * a file of a format added with
          :func:`slamq.sources.formats.register_format`. Every file format goes through
          the registry :mod:`slamq.sources.formats` (its ``read``, then one
          ``interpret`` step).
        * a uint8 image array (``HxW``, ``HxWx3``, ``HxWx4``): the image defaults.
        * an int8 nav_msgs/OccupancyGrid array (row 0 = bottom): see
          :func:`from_occupancy_grid`.
        * an :class:`OccupancyMap`: returned as is, unless an argument below changes it.
    unknown_value : int, optional
        Treat pixel == ``unknown_value`` as unknown, and nothing else (no thresholds, no
        205 rule, no alpha). The pixel is the file's grey level before ``negate`` (for
        RGB the rounded channel mean); for OccupancyGrid data it is the grid value (-1 and
        255 are the same). Re-applied to an :class:`OccupancyMap` through
        ``meta["pixels"]``, the loader's pixel array (for a hand-built map: its values).
    resolution : float, optional
        Metres per cell; overrides the YAML's.
    origin : (x, y, yaw), optional
        Overrides the YAML's origin.
    topic : str, optional
        For a bag: the nav_msgs/OccupancyGrid topic (default ``/map``).

    Returns
    -------
    OccupancyMap
        ``meta`` holds: ``kind`` (yaml, image, array, occupancy_grid, or what the bag
        reader says), ``mode``, ``negate``, ``occupied_thresh``, ``free_thresh``, ``yaml``
        and ``image`` paths, ``format``, ``channels``, ``resolution_from``,
        ``unknown_rule`` (which rule made cells unknown), ``warnings`` (the messages also
        issued as :class:`~slamq.errors.MapWarning`) and ``pixels`` (the grey pixel
        array before ``negate``; the same array as ``values`` when nothing changed it).

    Raises
    ------
    MapError
        The message starts with the file (or ``<array>``) and gives the reason:
        missing or unreadable file, truncated or corrupt image, a header claiming more
        cells than the file holds, 16-bit or float pixels, a YAML that does not parse or
        has no ``image``, an unknown mode, resolution <= 0, a map with zero cells, ...

    Examples
    --------
    >>> import numpy as np
    >>> from slamq import load_map
    >>> img = np.array([[0, 205], [254, 255]], np.uint8)     # map_saver's shades
    >>> m = load_map(img)
    >>> m.unknown.tolist(), m.meta["unknown_rule"]
    ([[False, True], [False, False]], 'map_saver: 205 unknown, 0/254/255 known')
    >>> load_map(img, unknown_value=255).unknown.tolist()
    [[False, False], [False, True]]
    """
    warnings_out: list[str] = []
    result = _load(source, unknown_value, resolution, origin, warnings_out, topic)
    for msg in warnings_out:
        warnings.warn(MapWarning(msg), stacklevel=2)
    return result


def _load(
    source: Any,
    unknown_value: int | None,
    resolution: Any,
    origin: Any,
    warnings_out: list[str],
    topic: str | None = None,
) -> OccupancyMap:
    if isinstance(source, OccupancyMap):
        where = source.source
        res = check_resolution(resolution, where)
        org = None if origin is None else check_origin(origin, where)
        return reapply(source, unknown_value, res, org)

    if isinstance(source, np.ndarray):
        where = "<array>"
        res = check_resolution(resolution, where)
        org = (0.0, 0.0, 0.0) if origin is None else check_origin(origin, where)
        if source.dtype == np.int8:
            if source.ndim != 2:
                raise fail(where, f"an int8 OccupancyGrid array must be 2-D, got "
                                   f"{source.ndim}-D (use from_occupancy_grid for flat data)")
            from slamq.sources.grids import from_occupancy_grid  # only for grid arrays

            grid = from_occupancy_grid(source, resolution=res, origin=org, source=where)
            return reapply(grid, unknown_value, None, None)
        if source.dtype != np.uint8:
            raise fail(where, f"unsupported array dtype {source.dtype}: expected a uint8 "
                               "image or an int8 OccupancyGrid")
        if source.size == 0:
            raise fail(where, "the map has zero cells")
        n = None if unknown_value is None else check_unknown_value(
            unknown_value, where, grid=False)
        grey, alpha, ch = split_channels(source, where)
        img = Image(np.ascontiguousarray(grey), alpha, ch, None, "array")
        return interpret(raw_image(img, where, kind="array"), unknown_value=n,
                         resolution=res, origin=org, warnings_out=warnings_out)

    if isinstance(source, (str, os.PathLike)):
        path = Path(os.fspath(source))
        where = str(path)
        res = check_resolution(resolution, where)
        org = None if origin is None else check_origin(origin, where)
        if unknown_value is not None:  # the widest range now, the mode's after reading
            check_unknown_value(unknown_value, where, grid=True)
        stat_path(path)  # missing, a broken link or a symlink loop: say which
        fmt = format_of(path)
        if fmt is None and path.is_dir():
            raise fail(where, "is a directory (not a ROS 2 bag); use "
                               "slamq.sources.discover_maps to find the maps in a folder")
        if fmt is None:
            fmt = get_format("image")  # an image of another suffix: the decoder says
        raw = read_raw(path, fmt, topic)
        grid = interpret(raw, unknown_value=unknown_value, resolution=res, origin=org,
                         warnings_out=warnings_out)
        if fmt.name == "image" and raw.image is not None:
            flagged = bare_image_flags(path, grid, raw.image)
            grid.meta["flags"] = [flag for flag, _ in flagged]
            warnings_out.extend(msg for _, msg in flagged)
        return grid

    raise MapError(f"<{type(source).__name__}>: cannot load a map from a "
                   f"{type(source).__name__}; expected a path, a numpy array or an OccupancyMap")


def load_map_bytes(
    data: bytes,
    *,
    source: str = "<stdin>",
    unknown_value: int | None = None,
    resolution: float | None = None,
) -> OccupancyMap:
    """Load a map from the bytes of an image file (PGM, PNG, ... as :func:`load_map` reads a
    bare image: map_server's defaults), e.g. an image piped into ``slamq eval -``.

    Examples
    --------
    >>> from slamq.sources.maps import load_map_bytes
    >>> m = load_map_bytes(b"P5 2 1 255 " + bytes([0, 254]))
    >>> m.source, m.shape, m.known_count
    ('<stdin>', (1, 2), 2)
    """
    warnings_out: list[str] = []
    res = check_resolution(resolution, source)
    n = None if unknown_value is None else check_unknown_value(unknown_value, source, grid=False)
    if len(data) > MAX_IMAGE_BYTES:
        raise fail(source, f"{len(data)} bytes is too large for an image")
    img = decode_image(data, source)
    result = interpret(raw_image(img, source), unknown_value=n, resolution=res,
                       warnings_out=warnings_out)
    for msg in warnings_out:
        warnings.warn(MapWarning(msg), stacklevel=2)
    return result


#: A bare image with more unknown cells than this (under the default thresholds) is
#: probably not a map_server map: a screenshot, or other grey levels.
MOSTLY_UNKNOWN = 0.9


def bare_image_warnings(path: Path, grid: OccupancyMap, img: Image) -> list[str]:
    """Why the numbers of an image loaded without its YAML may not mean what they seem:
    a YAML beside it names it, it is mostly unknown under map_server's default
    thresholds, or it has colour pixels (a screenshot).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (d / "m.pgm").write_bytes(b"P5 2 1 255 " + bytes([192, 192]))
    >>> _ = (d / "m.yaml").write_text("image: m.pgm\\n")
    >>> for w in bare_image_warnings(d / "m.pgm", *_grid_and_image(d / "m.pgm")):
    ...     print(w.split(": ", 1)[1][:58].strip())
    m.yaml beside it names this image: load the YAML to use it
    100.0% of the cells are unknown under map_server's default
    """
    return [msg for _, msg in bare_image_flags(path, grid, img)]


def bare_image_flags(path: Path, grid: OccupancyMap, img: Image) -> list[tuple[str, str]]:
    """:func:`bare_image_warnings` with a short flag for each (``yaml_beside``,
    ``mostly_unknown``, ``screenshot``); the flags go to ``meta["flags"]`` and from there
    to the record's ``flags`` column.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (d / "m.pgm").write_bytes(b"P5 2 1 255 " + bytes([192, 192]))
    >>> [f for f, _ in bare_image_flags(d / "m.pgm", *_grid_and_image(d / "m.pgm"))]
    ['mostly_unknown']
    """
    out = []
    for yaml_path in _yamls_naming(path):
        out.append(("yaml_beside", f"{path}: {yaml_path.name} beside it names this image: "
                    "load the YAML to use its resolution, origin and thresholds"))
    if grid.meta.get("unknown_rule", "").startswith("thresholds"):
        share = 1.0 - grid.known_count / grid.values.size
        if share > MOSTLY_UNKNOWN:
            out.append(("mostly_unknown",
                f"{path}: {100 * share:.1f}% of the cells are unknown under map_server's "
                "default thresholds (a screenshot, or a map saved with other grey levels?); "
                "pass unknown_value=N (--unknown-value N) or load its YAML"))
    if img.channels >= 3 and _has_colour(path):
        out.append(("screenshot",
                    f"{path}: has colour pixels, like a screenshot (RViz?) rather than a "
                    "saved map: its grey levels are not occupancy probabilities"))
    return out


def _grid_and_image(path: Path) -> tuple[OccupancyMap, Image]:
    """For the docstring example: the grid and decoded image of a bare image file."""
    img = read_image_file(path)
    return interpret(raw_image(img, str(path))), img


def _yamls_naming(path: Path, limit: int = 64) -> list[Path]:
    """The map YAMLs in ``path``'s folder (at most ``limit`` looked at) that name it."""
    try:
        folder = path.parent
        mtime = folder.stat().st_mtime_ns
        if time.time_ns() - mtime < 2_000_000_000:  # changed just now: the mtime's clock
            siblings = _yaml_siblings.__wrapped__(str(folder), mtime)[:limit]  # is coarse
        else:
            siblings = _yaml_siblings(str(folder), mtime)[:limit]
        target = path.resolve()
    except OSError:
        return []
    found = []
    for y in siblings:
        img = image_of(y)
        try:
            if img is not None and img.resolve() == target:
                found.append(y)
        except OSError:
            continue
    return found


@functools.lru_cache(maxsize=32)
def _yaml_siblings(folder: str, mtime_ns: int) -> tuple[Path, ...]:
    """The YAML files of ``folder``, sorted; cached while the folder's mtime (which any
    added, removed or renamed entry changes) stays the same, so that a batch over a folder
    of N bare images lists the folder once, not once per image (O(N^2))."""
    with os.scandir(folder) as entries:
        names = sorted(e.name for e in entries
                       if os.path.splitext(e.name)[1].lower() in YAML_SUFFIXES and e.is_file())
    return tuple(Path(folder, n) for n in names)


def _has_colour(path: Path) -> bool:
    """True when the colour image at ``path`` has pixels whose channels differ."""
    import cv2
    import numpy as np

    arr = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if arr is None:
        return False
    return bool(np.any(arr[..., 0] != arr[..., 1]) or np.any(arr[..., 1] != arr[..., 2]))
