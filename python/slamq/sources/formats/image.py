"""Bare images (PGM, PNG, JPEG, ...): a map without its YAML, read with map_server's
defaults (trinary, :data:`~slamq.sources.pixels.DEFAULT_OCCUPIED_THRESH` /
:data:`~slamq.sources.pixels.DEFAULT_FREE_THRESH`, no negate); the resolution comes from a
PGM comment like ``# CREATOR: map_saver.cpp 0.050 m/pix`` when there is one."""

from __future__ import annotations

from pathlib import Path

from slamq.sources.files import IMAGE_SUFFIXES
from slamq.sources.formats.raw import RawMap
from slamq.sources.images import Image, read_image_file

__all__ = ["NAME", "files", "raw_image", "read", "sniff"]

NAME = "image"
IN_FOLDERS = True


def sniff(path: Path) -> bool:
    """An image file by its suffix (:data:`~slamq.sources.files.IMAGE_SUFFIXES`).

    Examples
    --------
    >>> from pathlib import Path
    >>> sniff(Path("map.PGM")), sniff(Path("map.yaml"))
    (True, False)
    """
    return path.suffix.lower() in IMAGE_SUFFIXES


def files(path: Path) -> list[Path]:
    """The image alone."""
    return [path]


def raw_image(img: Image, source: str, kind: str = "image") -> RawMap:
    """A decoded image as a :class:`RawMap` with map_server's defaults.

    ``kind``: ``image`` for a file (``meta["image"]`` names it), ``array`` for pixels
    handed over in memory."""
    res_from = None if img.resolution_hint is None else "pgm comment"
    return RawMap(source, image=img, resolution=img.resolution_hint,
                  meta={"kind": kind, "image": source if kind == "image" else None,
                        "resolution_from": res_from})


def read(path: Path) -> RawMap:
    """Decode the image (bounded reads: :func:`~slamq.sources.images.read_image_file`).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "m.pgm"
    >>> _ = p.write_bytes(b"P5 2 1 255 " + bytes([0, 254]))
    >>> raw = read(p)
    >>> raw.mode, raw.occupied_thresh, raw.free_thresh, raw.resolution
    ('trinary', 0.65, 0.196, None)
    """
    return raw_image(read_image_file(path), str(path))
