"""Cartographer ``.pbstream`` files: the 2D submaps rasterised into one grid
(:func:`slamq.sources.pbstream_map.read_pbstream_map`). A pbstream holds a trajectory as
well, so the folder walk leaves it alone: name it to evaluate its map."""

from __future__ import annotations

from pathlib import Path

from slamq.sources.formats.raw import RawMap

__all__ = ["NAME", "files", "read", "sniff"]

NAME = "pbstream"
#: Not found by the folder walk (a pbstream beside its exported map would count twice).
IN_FOLDERS = False


def sniff(path: Path) -> bool:
    """A ``.pbstream`` file.

    Examples
    --------
    >>> from pathlib import Path
    >>> sniff(Path("run.pbstream")), sniff(Path("run.bag"))
    (True, False)
    """
    return path.suffix.lower() == ".pbstream"


def files(path: Path) -> list[Path]:
    """The pbstream alone."""
    return [path]


def read(path: Path) -> RawMap:
    """The rasterised submaps: cells already decoded (OccupancyGrid values)."""
    from slamq.sources.pbstream_map import read_pbstream_map

    return RawMap(str(path), grid=read_pbstream_map(path))
