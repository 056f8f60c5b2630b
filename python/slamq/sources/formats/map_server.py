"""ROS map_server maps: a YAML and the image it names (docs/spec.md section 1).

The one place slamq parses a map YAML: the folder walk (which YAMLs are maps, which
images they name), the batch's content hash (which files make the map) and the loader
all ask this module.
"""

from __future__ import annotations

import functools
import os
import stat
import time
from pathlib import Path
from typing import Any

import numpy as np

from slamq.errors import MapError
from slamq.models import OccupancyMap
from slamq.sources.files import (
    MAX_YAML_BYTES,
    YAML_SUFFIXES,
    as_float,
    check_origin,
    check_resolution,
    fail,
    load_yaml_safely,
    read_regular_file,
    reading_once,
    resolve_image,
    short_repr,
)
from slamq.sources.formats.raw import RawMap
from slamq.sources.images import read_image_file
from slamq.sources.pixels import (
    DEFAULT_FREE_THRESH,
    DEFAULT_MODE,
    DEFAULT_OCCUPIED_THRESH,
    MODES,
)

__all__ = ["NAME", "document", "files", "image_of", "is_map", "read", "sniff", "write",
           "write_raw_map"]

NAME = "map_server"
#: Found by the folder walk.
IN_FOLDERS = True

#: What :func:`document` gives for a YAML that cannot be read or parsed.
UNREADABLE = object()


def document(path: Path) -> Any:
    """The parsed YAML of a file met while searching; None when it is too large to be a
    map YAML; :data:`UNREADABLE` when it is not a regular file or does not parse.

    The document is the parse cache's own (:func:`slamq.sources.files.load_yaml_safely`
    with ``shared=True``): read it, do not change it.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "m.yaml"
    >>> _ = p.write_text("image: m.pgm\\n")
    >>> document(p)
    {'image': 'm.pgm'}
    """
    try:
        st = path.stat()
        if not stat.S_ISREG(st.st_mode):  # a FIFO would block the read below
            return UNREADABLE
        if st.st_size > MAX_YAML_BYTES:
            return None
        # The walk asks twice per YAML (is it a map, which image does it name): a file
        # unchanged for a while is read once. Inside read_once, and for a file changed just
        # now (the mtime's clock is coarse), it is read again.
        if reading_once() or time.time_ns() - st.st_mtime_ns < 2_000_000_000:
            return _parse(path)
        return _parse_unchanged(os.fspath(path), st.st_dev, st.st_ino, st.st_size,
                                st.st_mtime_ns)
    except (OSError, MapError):
        return UNREADABLE


def _parse(path: Path) -> Any:
    return load_yaml_safely(read_regular_file(path, "a map YAML", MAX_YAML_BYTES), path,
                            shared=True)  # only read


@functools.lru_cache(maxsize=1024)
def _parse_unchanged(path: str, dev: int, ino: int, size: int, mtime_ns: int) -> Any:
    """:func:`_parse` of a file as long as it keeps its device, inode, size and mtime."""
    return _parse(Path(path))


def is_map_document(doc: Any) -> bool:
    """A map YAML: a mapping with an ``image`` field, or one that cannot be parsed (so
    that loading it says why)."""
    return doc is UNREADABLE or (isinstance(doc, dict) and "image" in doc)


def image_of(path: Path, doc: Any = None) -> Path | None:
    """The image a map YAML names, resolved like the loader does (relative to the YAML's
    folder; an absolute path that does not exist falls back to the name beside the YAML).

    ``doc``: the YAML already parsed by :func:`document`.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (d / "m.yaml").write_text("image: /nowhere/m.pgm\\n")
    >>> image_of(d / "m.yaml") == d / "m.pgm"
    True
    """
    if doc is None:
        doc = document(path)
    if not isinstance(doc, dict) or not isinstance(doc.get("image"), str):
        return None
    return resolve_image(path, doc["image"])[0]


def sniff(path: Path) -> bool:
    """A ``.yaml``/``.yml`` file (the loader says why one that is no map YAML is refused).

    Examples
    --------
    >>> from pathlib import Path
    >>> sniff(Path("m.YML")), sniff(Path("m.pgm"))
    (True, False)
    """
    return path.suffix.lower() in YAML_SUFFIXES


def is_map(path: Path) -> bool:
    """For the folder walk: a YAML that is a map YAML (:func:`is_map_document`), not a
    configuration file.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (d / "m.yaml").write_text("image: m.pgm\\n")
    >>> _ = (d / "config.yaml").write_text("rate: 10\\n")
    >>> is_map(d / "m.yaml"), is_map(d / "config.yaml")
    (True, False)
    """
    return is_map_document(document(path))


def files(path: Path) -> list[Path]:
    """The YAML and the image it names (the YAML alone when it names none).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (d / "m.yaml").write_text("image: m.pgm\\nresolution: 0.05\\n")
    >>> [p.name for p in files(d / "m.yaml")]
    ['m.yaml', 'm.pgm']
    """
    img = image_of(path)
    return [path] if img is None else [path, img]


def _resolve_image(yaml_path: Path, image: str, warnings: list[tuple[str, str]]) -> Path:
    path, fell_back = resolve_image(yaml_path, image)
    if not fell_back:
        if not os.path.lexists(path):
            raise fail(yaml_path, f"image {short_repr(image)} not found (looked for {path})")
        return path  # a directory, a FIFO or a symlink loop is named when it is read
    if path.is_file():
        warnings.append(("", f"{yaml_path}: image {short_repr(image)} does not exist; using "
                             f"{path.name!r} beside the YAML"))
        return path
    raise fail(yaml_path, f"image {short_repr(image)} not found (also looked for {path})")


def read(path: Path) -> RawMap:
    """Read a map YAML and decode the image it names (the rule is applied by
    :func:`slamq.sources.formats.raw.interpret`).

    A ROS 2 bag's ``metadata.yaml`` gives the bag's last ``/map``.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (d / "m.pgm").write_bytes(b"P5 2 1 255 " + bytes([0, 254]))
    >>> _ = (d / "m.yaml").write_text("image: m.pgm\\nresolution: 0.05\\norigin: [1, 2, 0]\\n")
    >>> raw = read(d / "m.yaml")
    >>> raw.mode, raw.resolution, raw.origin, raw.image.grey.tolist()
    ('trinary', 0.05, (1.0, 2.0, 0.0), [[0, 254]])
    """
    raw = read_regular_file(path, "a map YAML", MAX_YAML_BYTES)
    doc = load_yaml_safely(raw, path, shared=True)  # only read
    if isinstance(doc, dict) and "rosbag2_bagfile_information" in doc:
        from slamq.sources.bag_maps import read_last_map

        return RawMap(str(path), grid=read_last_map(path.parent))
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
    warnings: list[tuple[str, str]] = []
    if free > occ and mode != "raw":
        warnings.append(("", f"{path}: free_thresh {free} > occupied_thresh {occ}: "
                             "no cell can be unknown by the thresholds"))

    # the file's resolution and origin: an error or a warning only when they are used
    errors: dict[str, MapError] = {}
    resolution: float | None = None
    res_from: str | None = None
    if "resolution" in doc:
        try:
            resolution = check_resolution(doc["resolution"], path)
            res_from = "yaml"
        except MapError as exc:
            errors["resolution"] = exc
    else:
        warnings.append(("resolution", f"{path}: the YAML has no 'resolution'"))
    origin = (0.0, 0.0, 0.0)
    if "origin" in doc:
        try:
            origin = check_origin(doc["origin"], path)
        except MapError as exc:
            errors["origin"] = exc
    else:
        warnings.append(("origin", f"{path}: the YAML has no 'origin'; using [0, 0, 0]"))

    image_path = _resolve_image(path, image, warnings)
    if image_path.suffix.lower() in YAML_SUFFIXES:
        raise fail(path, f"image {short_repr(image)} is a YAML file, not an image")
    try:
        img = read_image_file(image_path)
    except MapError as exc:
        raise MapError(f"{path}: {exc}") from None
    return RawMap(
        str(path), image=img, mode=mode, negate=negate, occupied_thresh=occ,
        free_thresh=free, resolution=resolution, origin=origin,
        meta={"kind": "yaml", "yaml": str(path), "image": str(image_path),
              "resolution_from": res_from},
        warnings=warnings, errors=errors, warn_disagreement=True,
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
           "occupied_thresh": DEFAULT_OCCUPIED_THRESH, "free_thresh": DEFAULT_FREE_THRESH}
    out.write_text(yaml.safe_dump(doc, sort_keys=False))
    return out


def write(grid: OccupancyMap, path: Path) -> Path:
    """Write ``grid`` as a map_server map at ``path`` (the YAML; the PGM beside it):
    ``mode: raw`` (:func:`write_raw_map`)."""
    return write_raw_map(grid, path)
