"""Snapshots: the numbered maps of one map being built (``map_0001.pgm``, ``map_0002.yaml``,
...). The one rule of what a snapshot is, for the folder walk (:mod:`slamq.sources.walk`:
snapshots are frames, not maps) and for the animations of the report and the runner
(:func:`find_snapshots`).

The rule: a map file (YAML or image) whose name ends in three or more digits, after an
optional ``_`` or ``-``, is snapshot number N of the series named by what comes before
(``map_0007`` -> series ``map``, number 7). A YAML wins over an image of the same number.
"""

from __future__ import annotations

import re
from pathlib import Path

from slamq.sources.files import IMAGE_SUFFIXES, YAML_SUFFIXES

__all__ = ["SNAPSHOT", "find_snapshots", "series", "snapshot_number"]

#: A map name ending in three or more digits: a snapshot of a map being built.
SNAPSHOT = re.compile(r"^(.*?)[_-]?(\d{3,})$")


def series(path: Path) -> str:
    """The name a snapshot shares with the other frames of its map (``map_0001`` -> ``map``;
    any other map: its own name).

    Examples
    --------
    >>> series(Path("runs/map_0001.pgm")), series(Path("office.yaml"))
    ('map', 'office')
    """
    m = SNAPSHOT.match(path.stem)
    return m.group(1) if m else path.stem


def snapshot_number(path: Path) -> int | None:
    """The snapshot number of a map file's name, or None when it is not one.

    Examples
    --------
    >>> snapshot_number(Path("map_0012.yaml")), snapshot_number(Path("map_12.pgm"))
    (12, None)
    """
    if path.suffix.lower() not in YAML_SUFFIXES | IMAGE_SUFFIXES:
        return None
    m = SNAPSHOT.match(path.stem)
    return int(m.group(2)) if m else None


def find_snapshots(folder: Path) -> list[Path]:
    """The snapshots in a folder (or, when it has none, its ``snapshots/`` subfolder), in
    order: the series with the most frames (the first by name of equals).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> for n in ("map_0002.pgm", "map_0001.pgm", "map_0001.yaml", "map.pgm"):
    ...     _ = (d / n).write_text("")
    >>> [p.name for p in find_snapshots(d)]
    ['map_0001.yaml', 'map_0002.pgm']
    """
    folder = Path(folder)
    for where in (folder, folder / "snapshots"):
        if not where.is_dir():
            continue
        found: dict[str, dict[int, Path]] = {}
        for p in sorted(where.iterdir()):
            k = snapshot_number(p)
            if k is None or not p.is_file():
                continue
            frames = found.setdefault(series(p), {})
            if k not in frames or p.suffix.lower() in YAML_SUFFIXES:
                frames[k] = p
        if found:
            best = max(sorted(found), key=lambda s: len(found[s]))
            return [found[best][k] for k in sorted(found[best])]
    return []
