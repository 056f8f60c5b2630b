"""Finding maps in folders: the one walk that ``slamq eval`` and ``slamq batch`` share.

Rules
-----
* A folder's maps are its map YAML files (``.yaml``/``.yml`` with an ``image`` field; one
  that cannot be parsed counts too, so that loading it says why) and its images
  (:data:`~slamq.sources.files.IMAGE_SUFFIXES`) that no YAML in the folder names.
* Numbered snapshots (``map_0001.pgm``: the rule of :mod:`slamq.sources.snapshots`, with
  another map of the same series beside it) are frames of the map being
  built, not maps: they are left out beside a non-numbered map, and a folder holding only
  snapshots gives its last one (by name). A lone dated name (``4_07_2022.yaml``) is a map.
* Folders are searched recursively; hidden entries (``.name``) and ROS 2 bag folders are
  skipped; symbolic links to folders are followed, each real folder once (a symlink loop
  ends there).
* Bags (``.bag``, ``.db3``, ``.mcap`` files and ROS 2 bag folders) found inside a folder are
  not maps: name a bag explicitly to evaluate its last ``/map``. A file named explicitly is
  always kept when it is a map file.
"""

from __future__ import annotations

import os
import stat
from collections import Counter
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

from slamq.errors import MapError
from slamq.sources.files import (
    IMAGE_SUFFIXES,
    MAX_YAML_BYTES,
    YAML_SUFFIXES,
    PathLike,
    is_bag,
    load_yaml_safely,
    resolve_image,
    stat_path,
)
from slamq.sources.snapshots import SNAPSHOT, series

__all__ = ["discover_maps", "folder_maps", "walk_folders", "yaml_image"]


#: What :func:`read_yaml` gives for a YAML that cannot be read or parsed.
UNREADABLE = object()


def read_yaml(path: Path) -> Any:
    """The parsed YAML of a file met while searching; None when it is too large to be a
    map YAML; :data:`UNREADABLE` when it is not a regular file or does not parse.

    The document is the parse cache's own (:func:`slamq.sources.files.load_yaml_safely`
    with ``shared=True``): read it, do not change it."""

    try:
        st = path.stat()
        if not stat.S_ISREG(st.st_mode):  # a FIFO would block the read below
            return UNREADABLE
        if st.st_size > MAX_YAML_BYTES:
            return None
        return load_yaml_safely(path.read_bytes(), path, shared=True)  # only read
    except (OSError, MapError):
        return UNREADABLE


def _is_map_doc(doc: Any) -> bool:
    return doc is UNREADABLE or (isinstance(doc, dict) and "image" in doc)


def yaml_image(path: Path, doc: Any = None) -> Path | None:
    """The image a map YAML names, resolved like the loader does (relative to the YAML's
    folder; an absolute path that does not exist falls back to the name beside the YAML).

    ``doc``: the YAML already parsed by :func:`read_yaml`.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (d / "m.yaml").write_text("image: /nowhere/m.pgm\\n")
    >>> yaml_image(d / "m.yaml") == d / "m.pgm"
    True
    """
    if doc is None:
        doc = read_yaml(path)
    if not isinstance(doc, dict) or not isinstance(doc.get("image"), str):
        return None
    return resolve_image(path, doc["image"])[0]


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
    docs = {p: read_yaml(p) for p in files if p.suffix.lower() in YAML_SUFFIXES}
    yamls = [p for p, doc in docs.items() if _is_map_doc(doc)]
    named_paths = {img for img in (yaml_image(y, docs[y]) for y in yamls) if img is not None}
    resolved: set[Path] | None = None  # resolved only for an image not named as it is

    def named(p: Path) -> bool:
        nonlocal resolved
        if not named_paths or p in named_paths:
            return bool(named_paths)
        if resolved is None:
            resolved = {_resolved(img) for img in named_paths}
        return _resolved(p) in resolved

    images = [p for p in files if p.suffix.lower() in IMAGE_SUFFIXES and not named(p)]
    maps = sorted(yamls + images)
    counts = Counter(series(p) for p in maps)
    snaps = [p for p in maps if SNAPSHOT.match(p.stem) and counts[series(p)] > 1]
    if snaps and len(snaps) < len(maps):
        maps = [p for p in maps if p not in snaps]
    elif snaps and len(snaps) == len(maps) and len(maps) > 1:
        maps = [maps[-1]]
    return maps


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
        files = sorted(here / n for n in names if not n.startswith("."))
        yield here, files, folder_maps(here, files)


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
        if is_bag(path):
            add(path)
        elif path.is_dir():
            for _, _, maps in walk_folders(path):
                for m in maps:
                    add(m)
        elif path.suffix.lower() in YAML_SUFFIXES | IMAGE_SUFFIXES:
            add(path)
        else:
            problems.append((str(path), "not a map file: expected a map YAML, an image "
                                        "(.pgm, .png, ...) or a ROS bag"))
    return found, problems
