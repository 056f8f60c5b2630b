"""The map formats slamq reads, in one registry: each format is one module (or object) with

* ``NAME``: a short name (``map_server``, ``image``, ``mrpt_grid``, ``pbstream``, ``bag``);
* ``sniff(path) -> bool``: is ``path`` a map of this format (cheap: suffix, a file
  beside it, a small header);
* ``files(path) -> list[Path]``: the files that make up the map (hashed by the batch,
  copied with it);
* ``read(path) -> RawMap`` (or an :class:`~slamq.models.OccupancyMap`): what the file
  holds, before :func:`~slamq.sources.formats.raw.interpret` (docs/spec.md section 1)
  turns it into cells; a format of containers takes ``topic=`` as well (readers
  without it ignore a topic);
* optional ``write(map, path)``, ``collect(src, dest_yaml, topic)`` (how a run's output
  of this format becomes a map_server map), ``IN_FOLDERS`` (found by the folder walk;
  default True), ``is_map(path)`` (for the walk: whether a file it sniffs is a map, e.g.
  a YAML that is no configuration file; default every one) and ``LARGE`` (files read by
  the format's own library, hashed in chunks; default False).

:func:`slamq.load_map`, the folder walk (:mod:`slamq.sources.walk`) and the batch's
content hash (:mod:`slamq.batch.records`) ask this registry; :func:`register_format`
adds a format for all of them.
"""

from __future__ import annotations

import dataclasses
import inspect
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import slamq.sources.formats.bag as bag
import slamq.sources.formats.image as image
import slamq.sources.formats.map_server as map_server
import slamq.sources.formats.mrpt_grid as mrpt_grid
import slamq.sources.formats.pbstream as pbstream
from slamq.errors import MapError
from slamq.models import OccupancyMap
from slamq.sources.files import PathLike, fail
from slamq.sources.formats.raw import RawMap, interpret

__all__ = ["MapFormat", "RawMap", "collect_map", "format_of", "found_in_folder", "get_format",
           "interpret", "map_files", "map_formats", "read_map", "register_format",
           "unregister_format"]


@dataclasses.dataclass(frozen=True)
class MapFormat:
    """One map format of the registry (see the module's description of the fields)."""

    name: str
    sniff: Callable[[Path], bool]
    files: Callable[[Path], list[Path]]
    read: Callable[..., Any]
    write: Callable[..., Any] | None = None
    collect: Callable[..., Path] | None = None
    is_map: Callable[[Path], bool] | None = None
    in_folders: bool = True
    large: bool = False

    @classmethod
    def of(cls, obj: Any) -> MapFormat:
        """The format a module or object describes (``NAME``/``name``, ``sniff``, ...).

        Examples
        --------
        >>> from slamq.sources.formats import image
        >>> MapFormat.of(image).name, MapFormat.of(image).in_folders
        ('image', True)
        """
        if isinstance(obj, MapFormat):
            return obj

        def get(*names: str, default: Any = None) -> Any:
            for n in names:
                if hasattr(obj, n):
                    return getattr(obj, n)
            return default

        name = get("NAME", "name")
        missing = [n for n in ("sniff", "files", "read") if not callable(get(n))]
        if not isinstance(name, str) or not name or missing:
            raise TypeError(f"{obj!r} is no map format: it needs a NAME and "
                            f"{', '.join(missing) or 'a non-empty name'}")
        return cls(name, get("sniff"), get("files"), get("read"), get("write"),
                   get("collect"), get("is_map"),
                   bool(get("IN_FOLDERS", "in_folders", default=True)),
                   bool(get("LARGE", "large", default=False)))


def _collect_raw(src: Path, dest_yaml: Path, topic: str | None = None) -> Path:
    """A bag's map (OccupancyGrid data), saved as map_server ``mode: raw``."""
    return map_server.write_raw_map(read_map(src, topic=topic), dest_yaml)


def _collect_pbstream(src: Path, dest_yaml: Path, topic: str | None = None) -> Path:
    """A pbstream's map (it has no topics), saved as map_server ``mode: raw``."""
    return map_server.write_raw_map(read_map(src), dest_yaml)


def _collect_mrpt(src: Path, dest_yaml: Path, topic: str | None = None) -> Path:
    """An MRPT grid: a map_server YAML naming its PNG (resolution, origin from the limits)."""
    return mrpt_grid.write_yaml(src, dest_yaml)


#: The built-in formats, most specific first (an MRPT grid is a PNG too).
_BUILTIN = (
    dataclasses.replace(MapFormat.of(bag), collect=_collect_raw),
    dataclasses.replace(MapFormat.of(pbstream), collect=_collect_pbstream),
    MapFormat.of(map_server),
    dataclasses.replace(MapFormat.of(mrpt_grid), collect=_collect_mrpt),
    MapFormat.of(image),
)
#: Formats added by :func:`register_format`, consulted before the built-in ones.
_ADDED: list[MapFormat] = []
#: The names a run configuration uses for some formats (``runner`` ``outputs.map.format``).
_ALIASES = {"yaml": "map_server", "mrpt": "mrpt_grid"}


def map_formats() -> tuple[MapFormat, ...]:
    """Every format, in the order they are asked: the registered ones, then the built-ins.

    Examples
    --------
    >>> [f.name for f in map_formats()]
    ['bag', 'pbstream', 'map_server', 'mrpt_grid', 'image']
    """
    return (*_ADDED, *_BUILTIN)


def register_format(fmt: Any) -> MapFormat:
    """Add a map format (a module or object with ``NAME``, ``sniff``, ``files``, ``read``):
    :func:`slamq.load_map`, ``slamq eval``, ``slamq batch`` and the folder walk find its
    maps from now on. It is asked before the built-in formats.

    Raises ``ValueError`` when a format of that name is registered already.

    Examples
    --------
    >>> import types
    >>> toy = types.SimpleNamespace(NAME="toy", sniff=lambda p: p.suffix == ".toy",
    ...                             files=lambda p: [p], read=lambda p: None)
    >>> register_format(toy).name
    'toy'
    >>> format_of(Path("a.toy")).name
    'toy'
    >>> unregister_format("toy")
    """
    f = MapFormat.of(fmt)
    if any(g.name == f.name for g in map_formats()):
        raise ValueError(f"a map format named {f.name!r} is registered already")
    _ADDED.insert(0, f)
    return f


def unregister_format(fmt: Any) -> None:
    """Remove a format added by :func:`register_format` (by name, module or object)."""
    name = fmt if isinstance(fmt, str) else MapFormat.of(fmt).name
    for i, f in enumerate(_ADDED):
        if f.name == name:
            del _ADDED[i]
            return
    raise ValueError(f"no registered map format named {name!r}")


def get_format(name: str) -> MapFormat:
    """The format of that name (``yaml`` and ``mrpt``, the run configuration's words, are
    ``map_server`` and ``mrpt_grid``).

    Examples
    --------
    >>> get_format("yaml").name
    'map_server'
    """
    name = _ALIASES.get(name, name)
    for f in map_formats():
        if f.name == name:
            return f
    raise MapError(f"no map format named {name!r} "
                   f"(known: {', '.join(f.name for f in map_formats())})")


def format_of(path: PathLike) -> MapFormat | None:
    """The first format that claims ``path``, or None.

    Examples
    --------
    >>> format_of("run.pbstream").name, format_of("notes.txt") is None
    ('pbstream', True)
    """
    p = Path(os.fspath(path))
    for f in map_formats():
        try:
            if f.sniff(p):
                return f
        except (OSError, ValueError):  # an unreadable neighbour: not this format
            continue
    return None


def found_in_folder(path: Path) -> MapFormat | None:
    """The format of a file the folder walk meets, when the file is a map there: the
    first format found in folders (``IN_FOLDERS``) that sniffs it, if its ``is_map``
    agrees.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (d / "config.yaml").write_text("rate: 10\\n")
    >>> found_in_folder(d / "m.png").name, found_in_folder(d / "config.yaml")
    ('image', None)
    """
    for f in map_formats():
        if not f.in_folders:  # its files are not maps here whatever it says (no stat)
            continue
        try:
            if not f.sniff(path):
                continue
            return f if f.is_map is None or f.is_map(path) else None
        except (OSError, ValueError):
            continue
    return None


def map_files(path: PathLike) -> list[Path]:
    """The files a map is made of (its format's ``files``; the path alone when no format
    claims it).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (d / "m.yaml").write_text("image: m.pgm\\nresolution: 0.05\\n")
    >>> [p.name for p in map_files(d / "m.yaml")]
    ['m.yaml', 'm.pgm']
    """
    p = Path(os.fspath(path))
    f = format_of(p)
    return [p] if f is None else list(f.files(p))


def read_raw(path: Path, fmt: MapFormat, topic: str | None = None) -> RawMap:
    """``fmt.read(path)`` as a :class:`RawMap`; ``topic`` goes to a reader that takes one
    (a container's: bags) and is ignored by the others, so that one ``--topic`` serves a
    mix of bags and map files."""
    got = fmt.read(path, topic=topic) if topic is not None and _takes_topic(fmt) else \
        fmt.read(path)
    if isinstance(got, OccupancyMap):
        return RawMap(got.source, grid=got)
    if not isinstance(got, RawMap):
        raise fail(path, f"the {fmt.name} reader gave a {type(got).__name__}, "
                         "not a RawMap or an OccupancyMap")
    return got


def _takes_topic(fmt: MapFormat) -> bool:
    try:
        params = inspect.signature(fmt.read).parameters
    except (TypeError, ValueError):
        return False
    return "topic" in params or any(p.kind is p.VAR_KEYWORD for p in params.values())


def read_map(
    path: PathLike,
    *,
    topic: str | None = None,
    unknown_value: int | None = None,
    resolution: float | None = None,
    origin: tuple[float, float, float] | None = None,
    warnings_out: list[str] | None = None,
) -> OccupancyMap:
    """Read a map file of any registered format: its format's ``read``, then
    :func:`~slamq.sources.formats.raw.interpret`. :func:`slamq.load_map` adds the
    argument checks and issues the warnings (``warnings_out`` collects them here).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "m.pgm"
    >>> _ = p.write_bytes(b"P5 2 1 255 " + bytes([0, 254]))
    >>> read_map(p, resolution=0.1).known_count
    2
    """
    p = Path(os.fspath(path))
    f = format_of(p)
    if f is None:
        raise fail(p, "not a map file: no map format reads it "
                      f"({', '.join(g.name for g in map_formats())})")
    raw = read_raw(p, f, topic)
    return interpret(raw, unknown_value=unknown_value, resolution=resolution, origin=origin,
                     warnings_out=warnings_out)


def collect_map(src: PathLike, dest_yaml: PathLike, *, format: str | None = None,
                topic: str | None = None) -> Path:
    """A map another program wrote, made into one every slamq tool shows and reloads:
    map_server YAMLs and images are checked readable and kept where they are; other
    formats are saved as a map_server map at ``dest_yaml`` (MRPT grids as a YAML naming
    the PNG; bags and pbstreams as ``mode: raw``). Returns the map to score.

    ``format``: the format's name (or the run configuration's ``yaml``/``mrpt``); default
    the one that claims ``src``. ``topic``: the map topic of a bag (other formats have
    none and ignore it).

    Examples
    --------
    >>> import pathlib, tempfile
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (d / "m.pgm").write_bytes(b"P5 2 1 255 " + bytes([0, 254]))
    >>> collect_map(d / "m.pgm", d / "map.yaml") == d / "m.pgm"
    True
    """
    s, dest = Path(os.fspath(src)), Path(os.fspath(dest_yaml))
    f = get_format(format) if format not in (None, "auto") else format_of(s)
    if f is None:
        raise fail(s, "not a map file: no map format reads it")
    if f.collect is not None:
        return f.collect(s, dest, topic)
    interpret(read_raw(s, f))  # readable?
    return s

