"""ROS map_server maps: a YAML and the image it names (SPEC section 1), and bare images with
map_server's defaults."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from slamq.errors import MapError
from slamq.models import OccupancyMap
from slamq.sources.files import (
    MAX_YAML_BYTES,
    YAML_SUFFIXES,
    as_float,
    check_origin,
    check_resolution,
    check_unknown_value,
    fail,
    load_yaml_safely,
    read_regular_file,
    resolve_image,
    short_repr,
)
from slamq.sources.images import Image, read_image_file
from slamq.sources.pixels import (
    DEFAULT_FREE_THRESH,
    DEFAULT_MODE,
    DEFAULT_OCCUPIED_THRESH,
    MODES,
    NEGATE,
    apply_lut,
    interpret,
    unknown_value_mask,
)


def image_map(
    img: Image,
    *,
    source: str,
    kind: str,
    unknown_value: int | None,
    resolution: float | None,
    origin: tuple[float, float, float],
    warnings_out: list[str],
) -> OccupancyMap:
    values, unknown, meta = interpret(
        img, mode=DEFAULT_MODE, negate=False, occ=DEFAULT_OCCUPIED_THRESH,
        free=DEFAULT_FREE_THRESH, unknown_value=unknown_value, where=source,
        warn_disagreement=False, warnings_out=warnings_out,
    )
    res_from = "argument" if resolution is not None else None
    if resolution is None and img.resolution_hint is not None:
        resolution, res_from = img.resolution_hint, "pgm comment"
    meta = {
        "kind": kind,
        "mode": DEFAULT_MODE,
        "negate": False,
        "occupied_thresh": DEFAULT_OCCUPIED_THRESH,
        "free_thresh": DEFAULT_FREE_THRESH,
        "yaml": None,
        "image": source if kind == "image" else None,
        "format": img.format,
        "channels": img.channels,
        "resolution_from": res_from,
        "warnings": list(warnings_out),
        "pixels": img.grey,
        **meta,
    }
    return OccupancyMap(values, unknown, resolution, origin, source, meta)


def _resolve_image(yaml_path: Path, image: str, warnings_out: list[str]) -> Path:
    path, fell_back = resolve_image(yaml_path, image)
    if not fell_back:
        if not os.path.lexists(path):
            raise fail(yaml_path, f"image {short_repr(image)} not found (looked for {path})")
        return path  # a directory, a FIFO or a symlink loop is named when it is read
    if path.is_file():
        warnings_out.append(
            f"{yaml_path}: image {short_repr(image)} does not exist; using {path.name!r} "
            "beside the YAML"
        )
        return path
    raise fail(yaml_path, f"image {short_repr(image)} not found (also looked for {path})")


def load_yaml_map(
    path: Path,
    *,
    unknown_value: int | None,
    resolution: float | None,
    origin: tuple[float, float, float] | None,
    warnings_out: list[str],
) -> OccupancyMap:
    raw = read_regular_file(path, "a map YAML", MAX_YAML_BYTES)
    doc = load_yaml_safely(raw, path, shared=True)  # only read
    if isinstance(doc, dict) and "rosbag2_bagfile_information" in doc:
        from slamq.sources.bag_maps import read_last_map

        return read_last_map(path.parent)
    if not isinstance(doc, dict):
        raise fail(path, "not a map YAML: expected a mapping with an 'image' field, "
                          f"got {type(doc).__name__}")
    image = doc.get("image")
    if image is None:
        raise fail(path, "the YAML has no 'image' field")
    if not isinstance(image, str) or not image.strip():
        raise fail(path, f"'image' must be a file name, got {short_repr(image)}")

    mode = doc.get("mode", DEFAULT_MODE)
    if not isinstance(mode, str) or mode.strip().lower() not in MODES:
        raise fail(path, f"unknown mode {short_repr(mode)} (expected trinary, scale or raw)")
    mode = mode.strip().lower()
    neg = doc.get("negate", 0)
    if isinstance(neg, bool):
        negate = neg
    elif isinstance(neg, (int, float)) and neg in (0, 1):
        negate = bool(neg)
    else:
        raise fail(path, f"negate must be 0, 1, true or false, got {short_repr(neg)}")
    occ = as_float(doc.get("occupied_thresh", DEFAULT_OCCUPIED_THRESH),
                    "occupied_thresh", path)
    free = as_float(doc.get("free_thresh", DEFAULT_FREE_THRESH), "free_thresh", path)
    for what, t in (("occupied_thresh", occ), ("free_thresh", free)):
        if not 0.0 <= t <= 1.0:
            raise fail(path, f"{what} must be in 0..1, got {t}")
    if free > occ and mode != "raw":
        warnings_out.append(f"{path}: free_thresh {free} > occupied_thresh {occ}: "
                            "no cell can be unknown by the thresholds")

    res_from: str | None = "argument"
    if resolution is None:
        if "resolution" in doc:
            resolution = check_resolution(doc["resolution"], path)
            res_from = "yaml"
        else:
            res_from = None
            warnings_out.append(f"{path}: the YAML has no 'resolution'")
    if origin is None:
        if "origin" in doc:
            origin = check_origin(doc["origin"], path)
        else:
            origin = (0.0, 0.0, 0.0)
            warnings_out.append(f"{path}: the YAML has no 'origin'; using [0, 0, 0]")

    # The unknown value's range depends on the mode (raw data may say -1).
    n = None if unknown_value is None else check_unknown_value(
        unknown_value, path, grid=mode == "raw")
    image_path = _resolve_image(path, image, warnings_out)
    if image_path.suffix.lower() in YAML_SUFFIXES:
        raise fail(path, f"image {short_repr(image)} is a YAML file, not an image")
    try:
        img = read_image_file(image_path)
    except MapError as exc:
        raise MapError(f"{path}: {exc}") from None
    values, unknown, interp = interpret(
        img, mode=mode, negate=negate, occ=occ, free=free, unknown_value=n,
        where=str(path), warn_disagreement=True, warnings_out=warnings_out,
    )
    meta = {
        "kind": "yaml",
        "mode": mode,
        "negate": negate,
        "occupied_thresh": occ,
        "free_thresh": free,
        "yaml": str(path),
        "image": str(image_path),
        "format": img.format,
        "channels": img.channels,
        "resolution_from": res_from,
        "warnings": list(warnings_out),
        "pixels": img.grey,
        **interp,
    }
    return OccupancyMap(values, unknown, resolution, origin, str(path), meta)


def reapply(
    m: OccupancyMap,
    unknown_value: int | None,
    resolution: float | None,
    origin: tuple[float, float, float] | None,
) -> OccupancyMap:
    """An OccupancyMap with ``unknown_value`` / resolution / origin re-applied."""
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


#: v of each OccupancyGrid value g = 0..100 (docs/spec.md section 1), and back.
_GRID_V = np.rint(255 * (100 - np.arange(101)) / 100).astype(np.int64)
_V_GRID = np.full(256, -1, np.int64)
_V_GRID[_GRID_V] = np.arange(101)


def write_raw_map(grid: OccupancyMap, yaml_path: str | os.PathLike[str]) -> Path:
    """Save a map that came from OccupancyGrid data (a bag, a pbstream) as map_server
    ``mode: raw`` (a PGM of the grid values 0..100, 255 unknown, and its YAML), which loads
    back to the same values, unknown cells, resolution and origin.

    Raises :class:`~slamq.errors.MapError` for a map holding a known value that no
    OccupancyGrid value gives (e.g. a scanned image): raw mode cannot hold it.

    Examples
    --------
    >>> import pathlib, tempfile, numpy as np, slamq
    >>> from slamq.sources import from_occupancy_grid
    >>> m = from_occupancy_grid(np.array([[0, 100], [-1, 37]], np.int8), resolution=0.05,
    ...                         origin=(1.0, -2.0, 0.0))
    >>> p = write_raw_map(m, pathlib.Path(tempfile.mkdtemp()) / "map.yaml")
    >>> back = slamq.load_map(p)
    >>> (back.values == m.values).all(), (back.unknown == m.unknown).all(), back.origin
    (np.True_, np.True_, (1.0, -2.0, 0.0))
    """
    import yaml

    out = Path(yaml_path)
    g = _V_GRID[grid.values.astype(np.int64)]
    if (g[~grid.unknown] < 0).any():
        raise MapError(f"{grid.source}: a known cell value is no OccupancyGrid value; "
                       "mode raw cannot hold this map")
    pixels = np.where(grid.unknown, 255, g).astype(np.uint8)
    pgm = out.with_suffix(".pgm")
    out.parent.mkdir(parents=True, exist_ok=True)
    h, w = pixels.shape
    pgm.write_bytes(f"P5\n{w} {h}\n255\n".encode() + pixels.tobytes())
    doc = {"image": pgm.name, "mode": "raw", "resolution": float(grid.resolution or 0.05),
           "origin": [float(v) for v in grid.origin], "negate": 0,
           "occupied_thresh": 0.65, "free_thresh": 0.196}
    out.write_text(yaml.safe_dump(doc, sort_keys=False))
    return out
