"""Finding maps in folders: the one walk that ``slamq eval`` and ``slamq batch`` share.

Rules
-----
* A folder's maps are the files a map format of the registry (:mod:`slamq.sources.formats`)
  finds in folders: map YAMLs (``.yaml``/``.yml`` with an ``image`` field; one that cannot
  be parsed counts too, so that loading it says why), MRPT grids (a PNG with its
  ``_limits.txt``), images (:data:`~slamq.sources.files.IMAGE_SUFFIXES`) and the formats
  added with :func:`~slamq.sources.formats.register_format`; a file that is part of
  another map there (the image a YAML names) is not a map of its own.
* Numbered snapshots (``map_0001.pgm``: the rule of :mod:`slamq.sources.snapshots`, with
  another map of the same series beside it) are frames of the map being
  built, not maps: they are left out beside a non-numbered map, and a folder holding only
  snapshots gives its last one (by name). A lone dated name (``4_07_2022.yaml``) is a map.
* Folders are searched recursively; hidden entries (``.name``) and ROS 2 bag folders are
  skipped; symbolic links to folders are followed, each real folder once (a symlink loop
  ends there).
* ``slamq run`` output folders mean final maps: a run folder (one holding ``run.json``)
  gives the one map its ``run.json`` names (else its ``map.yaml``), never the program's
  raw outputs or snapshots below it; an output root (one holding ``runs.csv`` or
  ``.slamq-cache.json``) is not searched in its ``report``, ``sequences`` (generated
  ground truth) and ``shards`` folders.
* Bags (``.bag``, ``.db3``, ``.mcap`` files and ROS 2 bag folders) and Cartographer
  ``.pbstream`` files found inside a folder are not maps: name one explicitly to evaluate
  its map. A file named explicitly is kept when a map format claims it.
"""

from __future__ import annotations

import os
from collections import Counter
from collections.abc import Iterable, Iterator
from pathlib import Path

from slamq.errors import MapError
from slamq.sources.files import PathLike, stat_path
from slamq.sources.formats import MapFormat, format_of, found_in_folder, map_formats
from slamq.sources.snapshots import SNAPSHOT, series

__all__ = ["discover_maps", "folder_maps", "walk_folders"]


def _resolved(path: Path) -> Path:
    """``path.resolve()``, or the absolute path when it cannot be resolved (a symlink loop)."""
    try:
        return path.resolve()
    except (OSError, RuntimeError):
        return path.absolute()


def folder_maps(folder: Path, files: list[Path] | None = None) -> list[Path]:
    """The maps directly in ``folder`` (the rules of :mod:`slamq.sources.walk`), sorted.

    ``files``: the folder's non-hidden files, when the caller has listed them already.
    """
    if files is None:
        files = sorted(p for p in folder.iterdir() if p.is_file() and not p.name.startswith("."))
    found = [(p, f) for p, f in ((p, found_in_folder(p)) for p in files) if f is not None]
    # the other files of a map (the image a YAML names, an MRPT grid's limits) are parts
    # of it, not maps of their own
    part_paths = {q for p, f in found for q in _files(f, p) if q != p}
    # Paths are resolved only when a part is named otherwise than as a file of this folder
    # or a symbolic link is involved; else the names compare as they are.
    listed = set(files)
    literal = not part_paths or not (
        any(q not in listed or q.is_symlink() for q in part_paths)
        or any(p.is_symlink() for p, _ in found if p not in part_paths))
    resolved: set[Path] | None = None

    def part(p: Path) -> bool:
        nonlocal resolved
        if p in part_paths or literal:
            return p in part_paths
        if resolved is None:
            resolved = {_resolved(q) for q in part_paths}
        return _resolved(p) in resolved

    maps = sorted(p for p, _ in found if not part(p))
    counts = Counter(series(p) for p in maps)
    snaps = [p for p in maps if SNAPSHOT.match(p.stem) and counts[series(p)] > 1]
    if snaps and len(snaps) < len(maps):
        maps = [p for p in maps if p not in snaps]
    elif snaps and len(snaps) == len(maps) and len(maps) > 1:
        maps = [maps[-1]]
    return maps


def _files(fmt: MapFormat, path: Path) -> list[Path]:
    try:
        return list(fmt.files(path))
    except (OSError, ValueError):
        return [path]


def walk_folders(root: Path) -> Iterator[tuple[Path, list[Path], list[Path]]]:
    """``(folder, files, maps)`` for ``root`` and every folder below it, top-down, sorted.

    ``files`` are the folder's non-hidden files, ``maps`` its maps (:func:`folder_maps`).
    """
    # (device, inode) of each folder walked, packed in one int: about 70 bytes per folder
    # (a resolved Path was about 350), the only memory the walk keeps per folder
    visited: set[int | str] = set()
    for folder, dirs, names in os.walk(root, followlinks=True):
        here = Path(folder)
        try:
            st = os.stat(here)
            real: int | str = (st.st_dev << 64) | st.st_ino
        except OSError:
            real = str(_resolved(here))
        if real in visited:  # a symlink cycle, or the same folder linked twice
            dirs[:] = []
            continue
        visited.add(real)
        dirs[:] = sorted(
            d for d in dirs  # os.path on strings: a Path per folder costs more than the stat
            if not d.startswith(".")
            and not os.path.isfile(os.path.join(folder, d, "metadata.yaml"))
        )
        if "run.json" in names:  # a slamq run's folder: its final map, nothing below
            dirs[:] = []
            files = sorted(here / n for n in names if not n.startswith("."))
            yield here, files, run_folder_map(here)
            continue
        if "runs.csv" in names or ".slamq-cache.json" in names:  # a slamq run's output
            dirs[:] = [d for d in dirs if d not in RUN_OUTPUT_SKIPPED]
        files = sorted(here / n for n in names if not n.startswith("."))
        yield here, files, folder_maps(here, files)


#: Folders of a ``slamq run`` output root that hold no run's map.
RUN_OUTPUT_SKIPPED = frozenset({"report", "sequences", "shards"})


def run_folder_map(folder: Path) -> list[Path]:
    """The final map of a ``slamq run`` run folder: the one its ``run.json`` names (found
    again below the folder when the output folder was moved), else its ``map.yaml``; none
    for a run that made no map.

    Examples
    --------
    >>> import json, pathlib, tempfile
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (d / "map.yaml").write_text("image: m.pgm")
    >>> _ = (d / "run.json").write_text(json.dumps({"map": "/elsewhere/1/map.yaml"}))
    >>> [p.name for p in run_folder_map(d)]
    ['map.yaml']
    """
    import json

    named = None
    try:
        named = json.loads((folder / "run.json").read_text()).get("map")
    except (OSError, ValueError, AttributeError):
        pass
    if isinstance(named, str) and named:
        p = Path(named)
        if p.is_file():
            return [p]
        parts = p.parts  # moved: the same path relative to a run folder of that name
        for k in range(len(parts) - 1, 0, -1):
            if parts[k - 1] == folder.name or k == len(parts) - 1:
                candidate = folder.joinpath(*parts[k:])
                if candidate.is_file():
                    return [candidate]
    fallback = folder / "map.yaml"
    return [fallback] if fallback.is_file() else []


def discover_maps(paths: PathLike | Iterable[PathLike]) -> tuple[list[Path], list[tuple[str, str]]]:
    """Find the maps in files and folders (folders are searched recursively).

    The rules are those of :mod:`slamq.sources.walk`, the same ``slamq batch`` uses.

    Parameters
    ----------
    paths : path or iterable of paths

    Returns
    -------
    maps : list of pathlib.Path
        In argument order, each folder's finds sorted; no duplicates.
    problems : list of (str, str)
        ``(path, reason)`` for missing paths and files that are not maps.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (d / "m.pgm").write_bytes(b"P5 1 1 255 " + bytes([254]))
    >>> _ = (d / "m.yaml").write_text("image: m.pgm\\nresolution: 0.05\\n")
    >>> _ = (d / "other.png").write_bytes(b"")
    >>> maps, problems = discover_maps([d, d / "gone.yaml"])
    >>> [p.name for p in maps], [(pathlib.Path(p).name, r) for p, r in problems]
    (['m.yaml', 'other.png'], [('gone.yaml', 'no such file or directory')])
    """
    if isinstance(paths, (str, os.PathLike)):
        paths = [paths]
    found: list[Path] = []
    problems: list[tuple[str, str]] = []
    seen: set[Path] = set()

    def add(p: Path) -> None:
        key = _resolved(p)
        if key not in seen:
            seen.add(key)
            found.append(p)

    for item in paths:
        path = Path(os.fspath(item))
        try:
            stat_path(path)
        except MapError as exc:
            msg, prefix = str(exc), f"{path}: "
            problems.append((str(path), msg[len(prefix):] if msg.startswith(prefix) else msg))
            continue
        if format_of(path) is not None:  # a map file, a bag: named, it is a map
            add(path)
        elif path.is_dir():
            for _, _, maps in walk_folders(path):
                for m in maps:
                    add(m)
        else:
            names = ", ".join(f.name for f in map_formats())
            problems.append((str(path), f"not a map file: no map format reads it ({names})"))
    return found, problems
