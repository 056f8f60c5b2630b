"""MRPT grid maps: ``COccupancyGridMap2D::saveAsBitmapFile`` writes an 8-bit grey PNG of the
cells' free probability (255 free, 0 occupied, about 128 unknown; first row = top =
``y_max``) and, beside it, ``<stem>_limits.txt`` with ``x_min x_max y_min y_max`` in metres
after a ``%`` comment line. The resolution is ``(x_max - x_min) / width`` and the origin
(lower-left corner) is ``(x_min, y_min)``; the pixels are read as a map_server image with
the default thresholds."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from slamq.errors import MapError
from slamq.sources.files import PathLike
from slamq.sources.formats.raw import RawMap
from slamq.sources.images import read_image_file
from slamq.sources.pixels import DEFAULT_FREE_THRESH, DEFAULT_OCCUPIED_THRESH

__all__ = ["NAME", "files", "limits_path", "read", "read_limits", "sniff", "write_yaml"]

NAME = "mrpt_grid"
IN_FOLDERS = True


def limits_path(png: PathLike) -> Path:
    """The ``_limits.txt`` file beside an MRPT grid image.

    Examples
    --------
    >>> limits_path("out/finalMap_COccupancyGridMap2D_00.png").name
    'finalMap_COccupancyGridMap2D_00_limits.txt'
    """
    p = Path(png)
    return p.with_name(p.stem + "_limits.txt")


def read_limits(path: PathLike) -> tuple[float, float, float, float]:
    """``(x_min, x_max, y_min, y_max)`` in metres from an MRPT ``_limits.txt`` file.

    Raises
    ------
    slamq.MapError
        The file is missing or does not hold four numbers with ``min < max``.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "m_limits.txt"
    >>> _ = p.write_text("% Grid limits: [x_min x_max y_min y_max]\\n-1.5 2.5 -3 1\\n")
    >>> read_limits(p)
    (-1.5, 2.5, -3.0, 1.0)
    """
    p = Path(path)
    try:
        text = p.read_text(errors="replace")
    except OSError as exc:
        raise MapError(f"{p}: cannot read MRPT grid limits ({exc.strerror or exc})") from exc
    numbers: list[float] = []
    for line in text.splitlines():
        line = line.split("%", 1)[0].strip()
        if not line:
            continue
        try:
            numbers.extend(float(x) for x in line.split())
        except ValueError:
            raise MapError(f"{p}: MRPT grid limits: not a number in {line!r}") from None
    if len(numbers) != 4 or not all(np.isfinite(numbers)):
        raise MapError(f"{p}: MRPT grid limits need 4 numbers (x_min x_max y_min y_max), "
                       f"found {len(numbers)}")
    x0, x1, y0, y1 = numbers
    if not (x1 > x0 and y1 > y0):
        raise MapError(f"{p}: MRPT grid limits are empty ({x0} {x1} {y0} {y1})")
    return x0, x1, y0, y1


def geometry(png: Path, width: int, height: int,
             limits: PathLike | None = None) -> tuple[float, float, float]:
    """``(resolution, x_min, y_min)`` of a ``width`` x ``height`` grid image from its limits.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (d / "g_limits.txt").write_text("0 0.4 0 0.2\\n")
    >>> geometry(d / "g.png", 8, 4)
    (0.05, 0.0, 0.0)
    """
    lim = Path(limits) if limits is not None else limits_path(png)
    x0, x1, y0, y1 = read_limits(lim)
    res = (x1 - x0) / width
    res_y = (y1 - y0) / height
    if abs(res - res_y) > 0.01 * res:
        raise MapError(f"{png}: MRPT limits {lim.name} give {res:g} m/cell across and "
                       f"{res_y:g} m/cell down for a {width}x{height} image")
    return res, x0, y0


def sniff(path: Path) -> bool:
    """A ``.png`` with a ``<stem>_limits.txt`` beside it.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (d / "g_limits.txt").write_text("0 0.4 0 0.2\\n")
    >>> sniff(d / "g.png"), sniff(d / "h.png")
    (True, False)
    """
    return path.suffix.lower() == ".png" and limits_path(path).is_file()


def files(path: Path) -> list[Path]:
    """The PNG and its limits file."""
    return [path, limits_path(path)]


def read(path: Path, limits: PathLike | None = None) -> RawMap:
    """Decode the PNG and its limits (``limits``: default ``<stem>_limits.txt`` beside it).

    Examples
    --------
    >>> import pathlib, tempfile, numpy as np, cv2
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = cv2.imwrite(str(d / "g.png"), np.full((4, 8), 255, np.uint8))
    >>> _ = (d / "g_limits.txt").write_text("0 0.4 0 0.2\\n")
    >>> raw = read(d / "g.png")
    >>> raw.resolution, raw.origin
    (0.05, (0.0, 0.0, 0.0))
    """
    lim = Path(limits) if limits is not None else limits_path(path)
    read_limits(lim)  # a missing or bad limits file is named before the image is decoded
    img = read_image_file(path)
    res, x0, y0 = geometry(path, img.grey.shape[1], img.grey.shape[0], lim)
    return RawMap(str(path), image=img, resolution=float(res),
                  origin=(float(x0), float(y0), 0.0),
                  meta={"kind": "mrpt_grid", "image": str(path), "resolution_from": "limits",
                        "mrpt_limits": str(lim)},
                  warn_disagreement=True)


def _image_size(png: Path) -> tuple[int, int]:
    import cv2

    img = cv2.imread(str(png), cv2.IMREAD_UNCHANGED)
    if img is None:
        raise MapError(f"{png}: not a readable image (MRPT grid map)")
    return img.shape[1], img.shape[0]


def write_yaml(png: PathLike, yaml_path: PathLike, limits: PathLike | None = None) -> Path:
    """Write a map_server YAML for an MRPT grid PNG (resolution and origin from its limits,
    map_server's default thresholds), so that any map_server tool reads the grid.

    The image is referenced by a path relative to the YAML's folder when possible.

    Examples
    --------
    >>> import pathlib, tempfile, numpy as np, cv2, slamq
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> img = np.full((10, 20), 255, np.uint8); img[0, :] = 0; img[5:, :] = 128
    >>> _ = cv2.imwrite(str(d / "g.png"), img)
    >>> _ = (d / "g_limits.txt").write_text("% limits\\n-1 1 0 1\\n")
    >>> m = slamq.load_map(write_yaml(d / "g.png", d / "map.yaml"))
    >>> m.resolution, m.origin, int((m.values == 0).sum()), int(m.unknown.sum())
    (0.1, (-1.0, 0.0, 0.0), 20, 100)
    """
    import yaml

    png = Path(png)
    lim = Path(limits) if limits is not None else limits_path(png)
    read_limits(lim)  # a missing or bad limits file is named before the image is opened
    res, x0, y0 = geometry(png, *_image_size(png), lim)
    out = Path(yaml_path)
    try:
        image = os.path.relpath(png.resolve(), out.parent.resolve())
    except ValueError:  # another drive (Windows)
        image = str(png.resolve())
    doc = {
        "image": image, "resolution": float(res), "origin": [float(x0), float(y0), 0.0],
        "negate": 0, "occupied_thresh": DEFAULT_OCCUPIED_THRESH,
        "free_thresh": DEFAULT_FREE_THRESH,
    }
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(yaml.safe_dump(doc, sort_keys=False))
    return out
