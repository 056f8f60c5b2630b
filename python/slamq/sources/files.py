"""What every reader shares: size budgets, file suffixes, the regular-file rule (never block
on a FIFO, never read more than the budget), and the checks of map metadata values."""

from __future__ import annotations

import contextlib
import contextvars
import functools
import math
import os
import stat
from collections.abc import Iterator
from pathlib import Path
from typing import Any, Union

import numpy as np

from slamq.errors import MapError, ParamError

#: What the readers accept as a file name.
PathLike = Union[str, "os.PathLike[str]"]

# ---------------------------------------------------------------------------------------
# Constants
# ---------------------------------------------------------------------------------------

#: Refuse images with more cells than this (OpenCV's own default limit is the same).
MAX_CELLS = 1 << 30
#: A map YAML larger than this is not a map YAML.
MAX_YAML_BYTES = 1 << 20
#: An image file larger than this is refused before it is read (MAX_CELLS RGBA pixels).
MAX_IMAGE_BYTES = 4 * MAX_CELLS + (1 << 20)
IMAGE_SUFFIXES = frozenset(
    (".pgm", ".pnm", ".ppm", ".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp")
)
YAML_SUFFIXES = frozenset((".yaml", ".yml"))
#: File suffixes read as bags (a folder holding ``metadata.yaml`` is a ROS 2 bag too).
BAG_SUFFIXES = (".bag", ".db3", ".mcap")


# ---------------------------------------------------------------------------------------
# Small helpers
# ---------------------------------------------------------------------------------------


def one_line(text: str) -> str:
    return " ".join(str(text).split())


def fail(where: Any, reason: str) -> MapError:
    return MapError(f"{where}: {reason}")


def as_float(value: Any, what: str, where: Any) -> float:
    if isinstance(value, bool) or value is None:
        raise fail(where, f"{what} must be a number, got {short_repr(value)}")
    try:
        out = float(value)
    except (TypeError, ValueError):
        raise fail(where, f"{what} must be a number, got {short_repr(value)}") from None
    if not math.isfinite(out):
        raise fail(where, f"{what} must be finite, got {short_repr(value)}")
    return out


def check_resolution(value: Any, where: Any) -> float | None:
    if value is None:
        return None
    res = as_float(value, "resolution", where)
    if not res > 0.0:
        raise fail(where, f"resolution must be > 0, got {short_repr(value)}")
    return res


def check_origin(value: Any, where: Any) -> tuple[float, float, float]:
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__"):
        raise fail(where, f"origin must be [x, y, yaw], got {short_repr(value)}")
    items = list(value)
    if len(items) not in (2, 3):
        raise fail(where, f"origin must be [x, y, yaw], got {short_repr(value)}")
    nums = [as_float(x, "origin", where) for x in items]
    if len(nums) == 2:
        nums.append(0.0)
    return (nums[0], nums[1], nums[2])


def check_unknown_value(value: Any, where: Any, *, grid: bool) -> int:
    """``unknown_value`` as the uint8 pixel it matches (for grids -1 means 255)."""

    lo = -128 if grid else 0
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ParamError(f"{where}: unknown_value must be an integer, got {short_repr(value)}")
    n = int(value)
    if not lo <= n <= 255:
        raise ParamError(f"{where}: unknown_value must be in {lo}..255, got {n}")
    return n % 256


def stat_path(path: Path) -> os.stat_result:
    """``os.stat`` of ``path``, or a MapError naming it and why (missing, a symlink loop)."""
    try:
        return path.stat()
    except FileNotFoundError:
        broken = path.is_symlink()
        raise fail(path, "broken symbolic link" if broken else "no such file or directory"
                    ) from None
    except (OSError, RuntimeError, ValueError) as exc:  # ValueError: a NUL byte in the path
        reason = getattr(exc, "strerror", None) or one_line(exc)
        raise fail(path, f"cannot read: {reason}") from None


#: The files read so far inside :func:`read_once` (None outside it).
_READ_ONCE: contextvars.ContextVar[dict[str, bytes] | None] = contextvars.ContextVar(
    "slamq_read_once", default=None)


@contextlib.contextmanager
def read_once() -> Iterator[dict[str, bytes]]:
    """Inside this block :func:`read_regular_file` reads each file from disk once: a second
    read of the same path gets the bytes of the first. The batch hashes a map's files and
    then decodes them from the same bytes, so a file replaced in between can never pair one
    file's hash with another's numbers.

    Yields the files read, path -> bytes, in the order they were first read.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "a.pgm"
    >>> _ = p.write_bytes(b"P5 1 1 255 \\x00")
    >>> with read_once() as reads:
    ...     first = read_regular_file(p, "an image", 100)
    ...     _ = p.write_bytes(b"P5 1 1 255 \\xff")  # replaced between the two reads
    ...     read_regular_file(p, "an image", 100) == first, list(reads) == [str(p)]
    (True, True)
    """
    outer = _READ_ONCE.get()
    reads: dict[str, bytes] = {} if outer is None else outer
    token = _READ_ONCE.set(reads)
    try:
        yield reads
    finally:
        _READ_ONCE.reset(token)


def reading_once() -> bool:
    """True inside :func:`read_once` (a reader must then read through
    :func:`read_regular_file`, never from a cache of its own).

    Examples
    --------
    >>> with read_once():
    ...     reading_once()
    True
    >>> reading_once()
    False
    """
    return _READ_ONCE.get() is not None


def read_regular_file(path: Path, what: str, limit: int) -> bytes:
    """The bytes of a regular file of at most ``limit`` bytes (never blocks on a FIFO);
    inside :func:`read_once`, the bytes of its first read."""
    reads = _READ_ONCE.get()
    if reads is not None:
        key = os.fspath(path)
        if key in reads:
            if len(reads[key]) > limit:
                raise fail(path, f"{len(reads[key])} bytes is too large for {what}")
            return reads[key]
        reads[key] = data = _read_regular_file(path, what, limit)
        return data
    return _read_regular_file(path, what, limit)


def _read_regular_file(path: Path, what: str, limit: int) -> bytes:
    st = stat_path(path)
    if stat.S_ISDIR(st.st_mode):
        raise fail(path, f"is a directory, not {what}")
    if not stat.S_ISREG(st.st_mode):
        raise fail(path, f"not a regular file (a FIFO, device or socket), not {what}")
    if st.st_size > limit:
        raise fail(path, f"{st.st_size} bytes is too large for {what}")
    try:
        with path.open("rb") as fh:
            return fh.read(st.st_size)  # a file still growing is cut at its size above
    except OSError as exc:
        raise fail(path, f"cannot read: {exc.strerror or exc}") from None


def is_bag(path: PathLike) -> bool:
    """True when ``path`` names a bag: a ``.bag``/``.db3``/``.mcap`` file or a ROS 2 folder.

    Examples
    --------
    >>> is_bag("run1.bag"), is_bag("map.yaml")
    (True, False)
    """
    p = Path(path)
    if p.suffix.lower() in BAG_SUFFIXES:
        return True
    return p.is_dir() and (p / "metadata.yaml").is_file()


def resolve_image(yaml_path: Path, image: str) -> tuple[Path, bool]:
    """Where the image a map YAML names is, as ROS map_server (and slamq) resolve it:
    relative to the YAML's folder; an absolute path that does not exist falls back to the
    file of that name beside the YAML. Returns ``(path, fell_back)``; the path may not exist.

    Examples
    --------
    >>> resolve_image(Path("maps/m.yaml"), "/nowhere/m.pgm")
    (PosixPath('maps/m.pgm'), True)
    """
    ref = Path(image)
    if not ref.is_absolute():
        return yaml_path.parent / ref, False
    if ref.is_file():
        return ref, False
    return yaml_path.parent / ref.name, True


def short_repr(value: Any, limit: int = 80) -> str:
    """``repr(value)`` cut to ``limit`` characters: error messages never print a huge
    rejected value (a YAML field can hold megabytes).

    Examples
    --------
    >>> short_repr("x" * 200)[-15:], len(short_repr("x" * 200))
    ('... (202 chars)', 95)
    """
    text = repr(value) if not isinstance(value, (list, dict)) or len(value) < 1000 else (
        f"<{type(value).__name__} of {len(value)} items>")
    if len(text) <= limit:
        return text
    return f"{text[:limit]}... ({len(text)} chars)"


def load_yaml_safely(raw: bytes, where: Any, *, shared: bool = False) -> Any:
    """Parse a map YAML with a safe loader, refusing anchors and aliases: a few hundred
    bytes of nested aliases ("billion laughs") would expand to gigabytes, and a map YAML
    has no use for them.

    ``shared=True``: the caller only reads the document, so it may get the cached one
    itself rather than a deep copy (a batch reads each map YAML three times: discovery,
    the content hash, the loader).

    Examples
    --------
    >>> load_yaml_safely(b"image: m.pgm\\nresolution: 0.05\\n", "m.yaml")
    {'image': 'm.pgm', 'resolution': 0.05}
    >>> load_yaml_safely(b"a: &x [1]\\nb: *x\\n", "m.yaml")
    Traceback (most recent call last):
    ...
    slamq.errors.MapError: m.yaml: YAML aliases (*x) are not allowed in a map YAML
    """
    import copy

    if len(raw) <= _YAML_CACHE_BYTES:
        doc, problem = _parse_yaml_cached(raw)
        if not shared:
            doc = copy.deepcopy(doc)  # the caller may change it; the cache keeps its own
    else:
        doc, problem = _parse_yaml(raw)
    if problem is not None:
        raise fail(where, problem)
    return doc


#: A batch parses each map YAML up to three times (discovery, the content hash, the
#: loader) from the same bytes: YAMLs up to this size are parsed once, by their bytes.
_YAML_CACHE_BYTES = 1 << 16


@functools.lru_cache(maxsize=4096)
def _parse_yaml_cached(raw: bytes) -> tuple[Any, str | None]:
    return _parse_yaml(raw)


def _parse_yaml(raw: bytes) -> tuple[Any, str | None]:
    """The document, or None and why it cannot be had (without the file's name)."""
    import yaml

    loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
    try:
        for event in yaml.parse(raw, Loader=loader):  # events only: nothing is expanded
            if isinstance(event, yaml.AliasEvent):
                return None, f"YAML aliases (*{event.anchor}) are not allowed in a map YAML"
        return yaml.load(raw, Loader=loader), None  # noqa: S506 - a safe loader
    except yaml.YAMLError as exc:
        return None, f"unparsable YAML: {one_line(exc)[:200]}"
    except UnicodeDecodeError:
        return None, "unparsable YAML: not UTF-8 text"
