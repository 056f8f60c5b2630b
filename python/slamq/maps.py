"""Loading occupancy grids: ROS map_server YAML + image, bare images, OccupancyGrid arrays.

SPEC.md section 1 is the contract. Every map is held image-style (row 0 at the top,
north up) as ``values`` (uint8, 0 = surely occupied, 255 = surely free) plus an
``unknown`` mask.

Choices the SPEC leaves open, made here:

* The *pixel* is the file's grey level (RGB/RGBA: ``rint`` of the mean of the colour
  channels), before ``negate``. The map_saver shade rule looks at pixels (all in
  {0, 205, 254, 255} -> 205 unknown) in ``trinary`` and ``scale`` modes, with or without
  ``negate``; ``unknown_value`` compares pixels too. ``scale`` still makes alpha < 255
  unknown under the shade rule.
* ``raw`` applies ``negate`` first, like ROS map_server. Unknown cells of ``raw`` maps and
  OccupancyGrid data hold 205 in ``values``; ``unknown_value`` that would make an
  out-of-range grid value known is refused (it has no occupancy).
* PGM/PPM with maxval < 255 are scaled as SDL_image (map_server's reader) does:
  ``x * 255 // maxval``. 16-bit and float images are refused.
* Decoding never allocates more than the file can hold: PGM sizes are checked against the
  file length, PNG sizes against zlib's best ratio, JPEG sizes against one bit per 8x8
  block, before any pixel buffer exists. Only regular files are read (never a FIFO).
* Per-pixel work is a 256-entry table (``cv2.LUT``): the unknown decision is computed once
  per pixel value with the SPEC formula ``p = (255 - v) / 255`` in float64, bounds inclusive.
"""

from __future__ import annotations

import math
import os
import re
import stat
import struct
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from slamq.errors import MapError, MapWarning

__all__ = [
    "OccupancyMap",
    "load_map",
    "from_occupancy_grid",
    "discover_maps",
    "MapError",
    "MapWarning",
]


@dataclass(frozen=True, eq=False)
class OccupancyMap:
    """An occupancy grid held image-style (row 0 = top = north).

    Attributes
    ----------
    values : numpy.ndarray
        ``(H, W)`` uint8, C-contiguous. 0 = surely occupied, 255 = surely free. The value
        of an unknown cell is whatever the file held; the metrics ignore it.
    unknown : numpy.ndarray
        ``(H, W)`` bool, C-contiguous; True where the cell is unknown.
    resolution : float or None
        Metres per cell (None for a bare image without metadata).
    origin : tuple of float
        ``(x, y, yaw)`` of the lower-left cell, ROS convention.
    source : str
        Where the map came from: a file path, or ``"<array>"``.
    meta : dict
        Loader details (mode, thresholds, negate, image path, warnings).

    Examples
    --------
    >>> import numpy as np
    >>> from slamq import OccupancyMap
    >>> m = OccupancyMap(np.full((2, 3), 254, np.uint8), np.zeros((2, 3), bool))
    >>> m.shape, m.known_count
    ((2, 3), 6)
    """

    values: np.ndarray
    unknown: np.ndarray
    resolution: float | None = None
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    source: str = "<array>"
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        values = np.asarray(self.values)
        unknown = np.asarray(self.unknown)
        if values.ndim != 2 or values.dtype != np.uint8:
            raise MapError(
                f"{self.source}: values must be a 2-D uint8 array, "
                f"got {values.ndim}-D {values.dtype}"
            )
        if unknown.shape != values.shape:
            raise MapError(
                f"{self.source}: unknown mask shape {unknown.shape} != values shape {values.shape}"
            )
        if values.size == 0:
            raise MapError(f"{self.source}: the map has zero cells")
        if self.resolution is not None and not (float(self.resolution) > 0.0):
            raise MapError(f"{self.source}: resolution must be > 0, got {self.resolution}")
        object.__setattr__(self, "values", np.ascontiguousarray(values))
        object.__setattr__(self, "unknown", np.ascontiguousarray(unknown, dtype=bool))

    @property
    def shape(self) -> tuple[int, int]:
        """``(H, W)`` in cells."""
        return (int(self.values.shape[0]), int(self.values.shape[1]))

    @property
    def known_count(self) -> int:
        """Number of known cells."""
        return int(self.unknown.size - np.count_nonzero(self.unknown))


# ---------------------------------------------------------------------------------------
# Constants
# ---------------------------------------------------------------------------------------

#: map_server's defaults for optional YAML fields (ROS 1 map_server and nav2 agree).
DEFAULT_OCCUPIED_THRESH = 0.65
DEFAULT_FREE_THRESH = 0.196
DEFAULT_MODE = "trinary"
#: The grey levels ROS map_saver writes: occupied, unknown, free (+ 255, also free).
MAP_SAVER_SHADES = frozenset((0, 205, 254, 255))
MAP_SAVER_UNKNOWN = 205
#: The value held for unknown cells of OccupancyGrid data and ``raw`` maps (map_saver's
#: unknown shade, so that a plain view of ``values`` looks like a map_saver image).
GRID_UNKNOWN_SHADE = 205
#: Refuse images with more cells than this (OpenCV's own default limit is the same).
MAX_CELLS = 1 << 30
#: A map YAML larger than this is not a map YAML.
_MAX_YAML_BYTES = 1 << 20
#: An image file larger than this is refused before it is read (MAX_CELLS RGBA pixels).
_MAX_IMAGE_BYTES = 4 * MAX_CELLS + (1 << 20)
#: zlib cannot compress better than about 1032:1; a PNG header claiming more raw bytes
#: than that allows is corrupt (or a decompression bomb), and is refused before decoding.
_DEFLATE_MAX_RATIO = 1032

IMAGE_SUFFIXES = frozenset(
    (".pgm", ".pnm", ".ppm", ".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".webp")
)
YAML_SUFFIXES = frozenset((".yaml", ".yml"))
BAG_SUFFIXES = frozenset((".bag", ".mcap", ".db3"))
_MODES = ("trinary", "scale", "raw")
_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_PNG_CHANNELS = {0: 1, 2: 3, 3: 3, 4: 2, 6: 4}
_WHITESPACE = b" \t\r\n\v\f"
_DIGITS = b"0123456789"
_RESOLUTION_COMMENT = re.compile(rb"([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*m/pix")

#: rint(s / 3) for every sum of three uint8 channels: the mean, rounded half to even.
_MEAN3_LUT = np.rint(np.arange(3 * 255 + 1, dtype=np.float64) / 3.0).astype(np.uint8)
_IDENTITY = np.arange(256, dtype=np.uint8)
_NEGATE = (255 - np.arange(256)).astype(np.uint8)


def _raw_value_lut() -> np.ndarray:
    """OccupancyGrid value (as uint8: -1 -> 255) to v, SPEC 1; out of 0..100 -> 205."""
    g = np.arange(256, dtype=np.float64)
    v = np.rint(255.0 * (100.0 - g) / 100.0)
    v[101:] = GRID_UNKNOWN_SHADE
    return v.astype(np.uint8)


_RAW_LUT = _raw_value_lut()


# ---------------------------------------------------------------------------------------
# Small helpers
# ---------------------------------------------------------------------------------------


def _one_line(text: str) -> str:
    return " ".join(str(text).split())


def _fail(where: Any, reason: str) -> MapError:
    return MapError(f"{where}: {reason}")


def _as_float(value: Any, what: str, where: Any) -> float:
    if isinstance(value, bool) or value is None:
        raise _fail(where, f"{what} must be a number, got {value!r}")
    try:
        out = float(value)
    except (TypeError, ValueError):
        raise _fail(where, f"{what} must be a number, got {value!r}") from None
    if not math.isfinite(out):
        raise _fail(where, f"{what} must be finite, got {value!r}")
    return out


def _check_resolution(value: Any, where: Any) -> float | None:
    if value is None:
        return None
    res = _as_float(value, "resolution", where)
    if not res > 0.0:
        raise _fail(where, f"resolution must be > 0, got {value!r}")
    return res


def _check_origin(value: Any, where: Any) -> tuple[float, float, float]:
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__"):
        raise _fail(where, f"origin must be [x, y, yaw], got {value!r}")
    items = list(value)
    if len(items) not in (2, 3):
        raise _fail(where, f"origin must be [x, y, yaw], got {value!r}")
    nums = [_as_float(x, "origin", where) for x in items]
    if len(nums) == 2:
        nums.append(0.0)
    return (nums[0], nums[1], nums[2])


def _check_unknown_value(value: Any, where: Any, *, grid: bool) -> int:
    """``unknown_value`` as the uint8 pixel it matches (for grids -1 means 255)."""
    from slamq.errors import ParamError

    lo = -128 if grid else 0
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ParamError(f"{where}: unknown_value must be an integer, got {value!r}")
    n = int(value)
    if not lo <= n <= 255:
        raise ParamError(f"{where}: unknown_value must be in {lo}..255, got {n}")
    return n % 256


# ---------------------------------------------------------------------------------------
# Image decoding: own PNM parser, PNG header checks, OpenCV for the rest
# ---------------------------------------------------------------------------------------


@dataclass
class _Image:
    grey: np.ndarray  # (H, W) uint8: the pixel, colour channels averaged
    alpha: np.ndarray | None  # (H, W) uint8 or None
    channels: int
    resolution_hint: float | None = None
    format: str = ""


def _skip_space_and_comments(data: bytes, pos: int, comments: list[bytes]) -> int:
    n = len(data)
    while pos < n:
        c = data[pos]
        if c in _WHITESPACE:
            pos += 1
        elif c == 0x23:  # '#': comment to end of line
            end = data.find(b"\n", pos)
            end = n if end < 0 else end
            comments.append(data[pos + 1 : end])
            pos = end + 1
        else:
            break
    return pos


def _parse_pnm(data: bytes, name: str) -> _Image:
    """Netpbm P2/P5 (grey) and P3/P6 (RGB), 8-bit, checked before any allocation."""
    magic = data[:2]
    if magic in (b"P1", b"P4"):
        raise _fail(name, "PBM bitmaps (P1/P4) are not supported; save the map as PGM (P5)")
    if magic == b"P7":
        raise _fail(name, "PAM (P7) images are not supported; save the map as PGM (P5)")
    ascii_ = magic in (b"P2", b"P3")
    channels = 3 if magic in (b"P3", b"P6") else 1
    kind = "PGM" if channels == 1 else "PPM"
    comments: list[bytes] = []
    fields: list[int] = []
    pos = 2
    while len(fields) < 3:
        pos = _skip_space_and_comments(data, pos, comments)
        if pos >= len(data):
            raise _fail(name, f"truncated {kind}: the header ends after {len(fields)} of "
                              "3 fields (width, height, maxval)")
        start = pos
        while pos < len(data) and data[pos] in _DIGITS:
            pos += 1
        if pos == start:
            raise _fail(name, f"bad {kind} header: expected a number at byte {start}, "
                              f"found {data[start:start + 1]!r}")
        if pos - start > 12:
            raise _fail(name, f"bad {kind} header: number too long at byte {start}")
        fields.append(int(data[start:pos]))
    width, height, maxval = fields
    if width == 0 or height == 0:
        raise _fail(name, f"the map has zero cells ({kind} header says {width}x{height})")
    if maxval == 0 or maxval > 65535:
        raise _fail(name, f"bad {kind} header: maxval {maxval} is outside 1..65535")
    if maxval > 255:
        raise _fail(name, f"16-bit {kind} (maxval {maxval}) is not supported; "
                          "save the map with 8-bit pixels")
    cells = width * height
    if cells > MAX_CELLS:
        raise _fail(name, f"{kind} header claims {width}x{height} = {cells} cells, "
                          f"more than the limit of {MAX_CELLS}")
    need = cells * channels
    if pos >= len(data) or data[pos] not in _WHITESPACE:
        if pos >= len(data):
            raise _fail(name, f"truncated {kind}: header says {width}x{height} "
                              f"({cells} cells) but the file has no pixel data")
        raise _fail(name, f"bad {kind} header: no whitespace after maxval")
    pos += 1
    if not ascii_:
        avail = len(data) - pos
        if avail < need:
            raise _fail(name, f"truncated {kind}: header says {width}x{height} "
                              f"({cells} cells, {need} bytes) but the file holds only "
                              f"{avail} bytes of pixel data")
        arr = np.frombuffer(data, dtype=np.uint8, count=need, offset=pos)
    else:
        rest = data[pos:]
        # Every ASCII sample takes at least one digit and one separator.
        if len(rest) < 2 * need - 1:
            raise _fail(name, f"truncated {kind}: header says {width}x{height} "
                              f"({cells} cells) but only {len(rest)} bytes follow")
        if b"#" in rest:
            rest = re.sub(rb"#[^\n]*", b" ", rest)
        tokens = rest.split(None, need)[:need]
        if len(tokens) < need:
            raise _fail(name, f"truncated {kind}: header says {width}x{height} "
                              f"({cells} cells, {need} samples) but the file holds "
                              f"only {len(tokens)} samples")
        try:
            wide = np.array(tokens, dtype=np.bytes_).astype(np.int64)
        except (ValueError, OverflowError):
            raise _fail(name, f"bad ASCII {kind}: a sample is not a decimal number "
                              "in 0..maxval") from None
        if wide.min() < 0:
            raise _fail(name, f"bad ASCII {kind}: negative sample")
        if wide.max() > maxval:
            raise _fail(name, f"bad {kind}: sample {int(wide.max())} exceeds maxval {maxval}")
        arr = wide.astype(np.uint8)
    if not ascii_ and maxval < 255:
        top = int(arr.max())
        if top > maxval:
            raise _fail(name, f"bad {kind}: sample {top} exceeds maxval {maxval}")
    if maxval < 255:
        # SDL_image (ROS map_server's reader) scales with integer division.
        lut = (np.arange(256, dtype=np.int64) * 255 // maxval).clip(0, 255).astype(np.uint8)
        arr = lut[arr]
    if channels == 1:
        grey = arr.reshape(height, width)
    else:
        grey = _MEAN3_LUT[arr.reshape(height, width, 3).sum(axis=2, dtype=np.uint16)]
    hint = None
    for c in comments:
        m = _RESOLUTION_COMMENT.search(c)
        if m:
            try:
                val = float(m.group(1))
            except ValueError:  # pragma: no cover - the regex only matches numbers
                continue
            if math.isfinite(val) and val > 0:
                hint = val
                break
    return _Image(grey, None, channels, hint, kind)


def _check_png_header(data: bytes, name: str) -> None:
    if len(data) < 33 or data[12:16] != b"IHDR":
        raise _fail(name, "truncated or corrupt PNG: no IHDR header")
    width, height = struct.unpack(">II", data[16:24])
    depth, ctype = data[24], data[25]
    if depth == 16:
        raise _fail(name, "16-bit PNG is not supported; save the map with 8-bit pixels")
    if ctype not in _PNG_CHANNELS or depth not in (1, 2, 4, 8):
        raise _fail(name, f"corrupt PNG: bit depth {depth}, colour type {ctype}")
    if width == 0 or height == 0:
        raise _fail(name, f"the map has zero cells (PNG header says {width}x{height})")
    cells = width * height
    if cells > MAX_CELLS:
        raise _fail(name, f"PNG header claims {width}x{height} = {cells} cells, "
                          f"more than the limit of {MAX_CELLS}")
    raw_bytes = height * (1 + (width * _PNG_CHANNELS[ctype] * depth + 7) // 8)
    if raw_bytes > _DEFLATE_MAX_RATIO * len(data) + 4096:
        raise _fail(name, f"corrupt or truncated PNG: the header claims {width}x{height} "
                          f"({cells} cells) but the file holds only {len(data)} bytes")
    if data.rfind(b"IEND") < 0:
        raise _fail(name, "truncated PNG: the file ends before its IEND chunk")


#: JPEG start-of-frame markers (baseline, progressive, lossless, arithmetic): they hold
#: the image size.
_JPEG_SOF = frozenset(range(0xC0, 0xD0)) - {0xC4, 0xC8, 0xCC}


def _check_jpeg_header(data: bytes, name: str) -> None:
    """Refuse a JPEG whose frame header claims more cells than the file can hold, or that
    ends before its EOI marker (libjpeg would fill the missing part with grey)."""
    pos = 2
    while pos + 4 <= len(data):
        if data[pos] != 0xFF:
            break
        marker = data[pos + 1]
        if marker == 0xFF:  # fill byte
            pos += 1
            continue
        length = struct.unpack(">H", data[pos + 2:pos + 4])[0]
        if marker in _JPEG_SOF:
            if pos + 9 > len(data):
                break
            height, width = struct.unpack(">HH", data[pos + 5:pos + 9])
            cells = width * height
            # at least one bit per 8x8 block and component, whatever the coding
            if cells > 512 * len(data) + 4096:
                raise _fail(name, f"corrupt or truncated JPEG: the header claims "
                                  f"{width}x{height} ({cells} cells) but the file holds only "
                                  f"{len(data)} bytes")
            break
        pos += 2 + length
    if data.rfind(b"\xff\xd9") < 0:
        raise _fail(name, "truncated JPEG: the file ends before its EOI marker")


def _split_channels(arr: np.ndarray, name: str) -> tuple[np.ndarray, np.ndarray | None, int]:
    """(grey, alpha, channels) of a uint8 image array: colour channels averaged (rint)."""
    if arr.ndim == 2:
        return arr, None, 1
    if arr.ndim != 3 or arr.shape[2] not in (1, 2, 3, 4):
        raise _fail(name, f"expected an HxW, HxWx3 or HxWx4 image, got shape {arr.shape}")
    ch = int(arr.shape[2])
    if ch == 1:
        return arr[:, :, 0], None, 1
    if ch == 2:
        return arr[:, :, 0], arr[:, :, 1], 2
    s = arr[:, :, 0].astype(np.uint16)
    s += arr[:, :, 1]
    s += arr[:, :, 2]
    grey = _MEAN3_LUT[s]
    return grey, (arr[:, :, 3] if ch == 4 else None), ch


def _decode_image(data: bytes, name: str) -> _Image:
    """Decode image bytes (any format) into grey + alpha, or raise MapError naming ``name``."""
    if len(data) == 0:
        raise _fail(name, "empty file")
    if data[:1] == b"P" and data[1:2] in b"1234567" and len(data) >= 2:
        return _parse_pnm(data, name)
    fmt = "image"
    if data[:8] == _PNG_SIGNATURE:
        _check_png_header(data, name)
        fmt = "PNG"
    elif data[:3] == b"\xff\xd8\xff":
        _check_jpeg_header(data, name)
        fmt = "JPEG"
    import cv2

    try:
        arr = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), cv2.IMREAD_UNCHANGED)
    except cv2.error as exc:
        raise _fail(name, f"cannot decode image: {_one_line(exc)}") from None
    if arr is None:
        if fmt == "PNG":
            raise _fail(name, "corrupt or truncated PNG: the decoder could not read it")
        raise _fail(name, "not a readable image (unknown format, or corrupt data)")
    if arr.dtype != np.uint8:
        raise _fail(name, f"{arr.dtype} pixels: 16-bit and float images are not supported; "
                          "save the map with 8-bit pixels")
    if arr.size == 0:
        raise _fail(name, "the map has zero cells")
    grey, alpha, ch = _split_channels(arr, name)
    return _Image(np.ascontiguousarray(grey), alpha, ch, None, fmt)


def _stat(path: Path) -> os.stat_result:
    """``os.stat`` of ``path``, or a MapError naming it and why (missing, a symlink loop)."""
    try:
        return path.stat()
    except FileNotFoundError:
        broken = path.is_symlink()
        raise _fail(path, "broken symbolic link" if broken else "no such file or directory"
                    ) from None
    except (OSError, RuntimeError) as exc:
        reason = getattr(exc, "strerror", None) or _one_line(exc)
        raise _fail(path, f"cannot read: {reason}") from None


def _read_regular_file(path: Path, what: str, limit: int) -> bytes:
    """The bytes of a regular file of at most ``limit`` bytes (never blocks on a FIFO)."""
    st = _stat(path)
    if stat.S_ISDIR(st.st_mode):
        raise _fail(path, f"is a directory, not {what}")
    if not stat.S_ISREG(st.st_mode):
        raise _fail(path, f"not a regular file (a FIFO, device or socket), not {what}")
    if st.st_size > limit:
        raise _fail(path, f"{st.st_size} bytes is too large for {what}")
    try:
        with path.open("rb") as fh:
            return fh.read(st.st_size)  # a file still growing is cut at its size above
    except OSError as exc:
        raise _fail(path, f"cannot read: {exc.strerror or exc}") from None


def _read_image_file(path: Path) -> _Image:
    return _decode_image(_read_regular_file(path, "an image", _MAX_IMAGE_BYTES), str(path))


# ---------------------------------------------------------------------------------------
# Pixel -> (values, unknown): SPEC section 1
# ---------------------------------------------------------------------------------------


def _apply_lut(img: np.ndarray, table: np.ndarray) -> np.ndarray:
    """``table[img]`` for a uint8 image and a 256-entry uint8 table (OpenCV: ~4x numpy)."""
    import cv2

    out = cv2.LUT(img, table)
    return out.reshape(img.shape)


def _present_values(img: np.ndarray) -> np.ndarray:
    """The distinct pixel values of a uint8 image (a 256-bin histogram's non-empty bins)."""
    import cv2

    hist = cv2.calcHist([np.ascontiguousarray(img)], [0], None, [256], [0, 256])
    return np.flatnonzero(hist.ravel())


def _threshold_unknown_lut(negate: bool, occ: float, free: float) -> np.ndarray:
    """Unknown decision for each pixel 0..255: free <= p <= occ, p = (255 - v) / 255."""
    pix = np.arange(256, dtype=np.int64)
    v = 255 - pix if negate else pix
    p = (255 - v).astype(np.float64) / 255.0
    return (free <= p) & (p <= occ)


def _interpret(
    img: _Image,
    *,
    mode: str,
    negate: bool,
    occ: float,
    free: float,
    unknown_value: int | None,
    where: str,
    warn_disagreement: bool,
    warnings_out: list[str],
) -> tuple[np.ndarray, np.ndarray, dict[str, Any]]:
    grey = img.grey
    meta: dict[str, Any] = {}
    if mode == "raw":
        g = _apply_lut(grey, _NEGATE) if negate else grey
        values = _apply_lut(g, _RAW_LUT)
        if unknown_value is None:
            unknown = g > 100
            meta["unknown_rule"] = "raw: values outside 0..100"
        else:
            unknown = _unknown_value_mask(grey, g, unknown_value, where)
            meta["unknown_rule"] = f"unknown_value={unknown_value}"
        return values, unknown, meta

    values = _apply_lut(grey, _NEGATE) if negate else grey
    if unknown_value is not None:
        meta["unknown_rule"] = f"unknown_value={unknown_value}"
        return values, grey == unknown_value, meta

    present = _present_values(grey)
    lut = _threshold_unknown_lut(negate, occ, free)
    if set(present.tolist()) <= MAP_SAVER_SHADES:
        rule = np.zeros(256, dtype=bool)
        rule[MAP_SAVER_UNKNOWN] = True
        differ = present[lut[present] != rule[present]]
        if warn_disagreement and differ.size:
            shades = ", ".join(str(int(x)) for x in differ)
            warnings_out.append(
                f"{where}: the YAML thresholds (occupied_thresh {occ}, free_thresh {free}"
                f"{', negate 1' if negate else ''}) would classify map_saver shade(s) "
                f"{shades} differently; using the map_saver rule (205 unknown, 0/254/255 known)"
            )
        lut = rule
        meta["unknown_rule"] = "map_saver: 205 unknown, 0/254/255 known"
    else:
        meta["unknown_rule"] = f"thresholds: {free} <= p <= {occ}"
    unknown = _apply_lut(grey, lut.astype(np.uint8)).view(bool)
    if mode == "scale" and img.alpha is not None:
        unknown |= img.alpha < 255
        meta["unknown_rule"] += "; alpha < 255"
    return values, unknown, meta


def _unknown_value_mask(
    pixels: np.ndarray, grid_values: np.ndarray, n: int, where: str
) -> np.ndarray:
    """``pixels == n`` for raw data; refuse to call out-of-range grid values known."""
    unknown = pixels == n
    bad = (grid_values > 100) & ~unknown
    if bad.any():
        first = int(grid_values[bad].flat[0])
        signed = first - 256 if first > 127 else first
        raise _fail(where, f"unknown_value={n} leaves cells with OccupancyGrid value "
                           f"{signed} (outside 0..100) known, but they have no occupancy")
    return unknown


# ---------------------------------------------------------------------------------------
# Sources
# ---------------------------------------------------------------------------------------


def _is_bag(path: Path) -> bool:
    if path.suffix.lower() in BAG_SUFFIXES:
        return True
    return path.is_dir() and (path / "metadata.yaml").is_file()


def _load_bag(path: Path) -> OccupancyMap:
    try:
        from slamq import bags
    except ImportError as exc:
        raise _fail(path, f"reading ROS bags needs slamq.bags, which is not available "
                          f"({_one_line(exc)})") from None
    reader = getattr(bags, "read_last_map", None)
    if reader is None:
        raise _fail(path, "reading ROS bags needs slamq.bags.read_last_map, which is missing")
    result = reader(path)
    if not isinstance(result, OccupancyMap):
        raise _fail(path, f"slamq.bags.read_last_map returned {type(result).__name__}, "
                          "not an OccupancyMap")
    return result


def _image_map(
    img: _Image,
    *,
    source: str,
    kind: str,
    unknown_value: int | None,
    resolution: float | None,
    origin: tuple[float, float, float],
    warnings_out: list[str],
) -> OccupancyMap:
    values, unknown, meta = _interpret(
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
    ref = Path(image)
    if not ref.is_absolute():
        candidate = yaml_path.parent / ref
        if not os.path.lexists(candidate):
            raise _fail(yaml_path, f"image {image!r} not found (looked for {candidate})")
        return candidate  # a directory, a FIFO or a symlink loop is named when it is read
    if ref.is_file():
        return ref
    beside = yaml_path.parent / ref.name
    if beside.is_file():
        warnings_out.append(
            f"{yaml_path}: image {image!r} does not exist; using {ref.name!r} beside the YAML"
        )
        return beside
    raise _fail(yaml_path, f"image {image!r} not found (also looked for {beside})")


def _load_yaml(
    path: Path,
    *,
    unknown_value: int | None,
    resolution: float | None,
    origin: tuple[float, float, float] | None,
    warnings_out: list[str],
) -> OccupancyMap:
    import yaml

    raw = _read_regular_file(path, "a map YAML", _MAX_YAML_BYTES)
    loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
    try:
        doc = yaml.load(raw, Loader=loader)  # noqa: S506 - a safe loader
    except yaml.YAMLError as exc:
        raise _fail(path, f"unparsable YAML: {_one_line(exc)}") from None
    except UnicodeDecodeError:
        raise _fail(path, "unparsable YAML: not UTF-8 text") from None
    if isinstance(doc, dict) and "rosbag2_bagfile_information" in doc:
        return _load_bag(path.parent)
    if not isinstance(doc, dict):
        raise _fail(path, "not a map YAML: expected a mapping with an 'image' field, "
                          f"got {type(doc).__name__}")
    image = doc.get("image")
    if image is None:
        raise _fail(path, "the YAML has no 'image' field")
    if not isinstance(image, str) or not image.strip():
        raise _fail(path, f"'image' must be a file name, got {image!r}")

    mode = doc.get("mode", DEFAULT_MODE)
    if not isinstance(mode, str) or mode.strip().lower() not in _MODES:
        raise _fail(path, f"unknown mode {mode!r} (expected trinary, scale or raw)")
    mode = mode.strip().lower()
    neg = doc.get("negate", 0)
    if isinstance(neg, bool):
        negate = neg
    elif isinstance(neg, (int, float)) and neg in (0, 1):
        negate = bool(neg)
    else:
        raise _fail(path, f"negate must be 0, 1, true or false, got {neg!r}")
    occ = _as_float(doc.get("occupied_thresh", DEFAULT_OCCUPIED_THRESH),
                    "occupied_thresh", path)
    free = _as_float(doc.get("free_thresh", DEFAULT_FREE_THRESH), "free_thresh", path)
    for what, t in (("occupied_thresh", occ), ("free_thresh", free)):
        if not 0.0 <= t <= 1.0:
            raise _fail(path, f"{what} must be in 0..1, got {t}")
    if free > occ and mode != "raw":
        warnings_out.append(f"{path}: free_thresh {free} > occupied_thresh {occ}: "
                            "no cell can be unknown by the thresholds")

    res_from: str | None = "argument"
    if resolution is None:
        if "resolution" in doc:
            resolution = _check_resolution(doc["resolution"], path)
            res_from = "yaml"
        else:
            res_from = None
            warnings_out.append(f"{path}: the YAML has no 'resolution'")
    if origin is None:
        if "origin" in doc:
            origin = _check_origin(doc["origin"], path)
        else:
            origin = (0.0, 0.0, 0.0)
            warnings_out.append(f"{path}: the YAML has no 'origin'; using [0, 0, 0]")

    # The unknown value's range depends on the mode (raw data may say -1).
    n = None if unknown_value is None else _check_unknown_value(
        unknown_value, path, grid=mode == "raw")
    image_path = _resolve_image(path, image, warnings_out)
    if image_path.suffix.lower() in YAML_SUFFIXES:
        raise _fail(path, f"image {image!r} is a YAML file, not an image")
    try:
        img = _read_image_file(image_path)
    except MapError as exc:
        raise MapError(f"{path}: {exc}") from None
    values, unknown, interp = _interpret(
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


def _reapply(
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
        n = _check_unknown_value(unknown_value, m.source, grid=grid)
        pixels = meta.get("pixels")
        if not isinstance(pixels, np.ndarray) or pixels.shape != m.values.shape:
            pixels = m.values  # a hand-built map: its values are its pixels
        if grid:
            g = _apply_lut(pixels, _NEGATE) if meta.get("negate") else pixels
            unknown = _unknown_value_mask(pixels, g, n, m.source)
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


def from_occupancy_grid(
    data: Any,
    *,
    width: int | None = None,
    height: int | None = None,
    resolution: float | None,
    origin: Any = (0.0, 0.0, 0.0),
    source: str = "<OccupancyGrid>",
) -> OccupancyMap:
    """Build a map from nav_msgs/OccupancyGrid data (row 0 = bottom), flipped north up.

    Values -1 (and anything outside 0..100) are unknown; a known value g becomes
    ``v = rint(255 * (100 - g) / 100)`` (half to even), SPEC section 1. Unknown cells hold
    205 in ``values`` (map_saver's unknown shade).

    Parameters
    ----------
    data : array-like of int8 (or integers in -128..127)
        ``(height, width)``, or flat of length ``width * height`` in message order.
    width, height : int, optional
        Needed when ``data`` is flat; checked when it is 2-D.
    resolution : float or None
        Metres per cell (``info.resolution``).
    origin : (x, y, yaw)
        Pose of the lower-left cell (``info.origin``, yaw from its quaternion).
    source : str
        Named in errors and kept as ``OccupancyMap.source``.

    Returns
    -------
    OccupancyMap

    Examples
    --------
    >>> import numpy as np
    >>> from slamq.maps import from_occupancy_grid
    >>> m = from_occupancy_grid(np.array([0, 100, -1, 50], np.int8), width=2, height=2,
    ...                         resolution=0.05)
    >>> m.values.tolist(), m.unknown.tolist()   # row 0 of the message is the bottom
    ([[205, 128], [255, 0]], [[True, False], [False, False]])
    """
    res = _check_resolution(resolution, source)
    org = _check_origin(origin, source)
    arr = np.asarray(data)
    if arr.dtype != np.int8:
        if arr.dtype.kind not in "iu" or arr.dtype == np.bool_:
            raise _fail(source, f"OccupancyGrid data must be int8, got {arr.dtype}")
        if arr.size and (arr.min() < -128 or arr.max() > 127):
            raise _fail(source, "OccupancyGrid data must be in -128..127 (int8)")
        arr = arr.astype(np.int8)
    for what, val in (("width", width), ("height", height)):
        if val is not None and (isinstance(val, bool) or not isinstance(val, (int, np.integer))
                                or val < 0):
            raise _fail(source, f"{what} must be a non-negative integer, got {val!r}")
    if arr.ndim == 1:
        if width is None or height is None:
            raise _fail(source, "flat OccupancyGrid data needs width and height")
        if arr.size != int(width) * int(height):
            raise _fail(source, f"OccupancyGrid data has {arr.size} cells, but width x height "
                                f"= {width} x {height} = {int(width) * int(height)}")
        arr = arr.reshape(int(height), int(width))
    elif arr.ndim == 2:
        if (width is not None and arr.shape[1] != width) or (
            height is not None and arr.shape[0] != height
        ):
            raise _fail(source, f"OccupancyGrid data shape {arr.shape} != "
                                f"(height, width) = ({height}, {width})")
    else:
        raise _fail(source, f"OccupancyGrid data must be 1-D or 2-D, got {arr.ndim}-D")
    if arr.size == 0:
        raise _fail(source, "the map has zero cells")
    pixels = np.ascontiguousarray(arr[::-1]).view(np.uint8)
    meta = {
        "kind": "occupancy_grid",
        "mode": "raw",
        "negate": False,
        "occupied_thresh": None,
        "free_thresh": None,
        "yaml": None,
        "image": None,
        "format": "OccupancyGrid",
        "channels": 1,
        "resolution_from": None if res is None else "argument",
        "warnings": [],
        "pixels": pixels,
        "unknown_rule": "OccupancyGrid: values outside 0..100",
    }
    return OccupancyMap(_apply_lut(pixels, _RAW_LUT), pixels > 100, res, org, source, meta)


def load_map(
    source: Any,
    *,
    unknown_value: int | None = None,
    resolution: float | None = None,
    origin: Any = None,
) -> OccupancyMap:
    """Load an occupancy grid from a file, an array or a bag, per SPEC.md section 1.

    Parameters
    ----------
    source : str, os.PathLike, numpy.ndarray or OccupancyMap
        * a ROS map_server YAML (``.yaml``/``.yml``) and the image it names (PGM, PNG or
          anything OpenCV reads; grey, RGB or RGBA; modes ``trinary``, ``scale``, ``raw``;
          ``negate``). An absolute ``image:`` path that does not exist falls back to the
          file of that name beside the YAML, with a :class:`~slamq.errors.MapWarning`.
        * a bare image: map_server's defaults (trinary, 0.65 / 0.196, no negate); the
          resolution comes from a PGM comment like ``# CREATOR: map_saver.cpp 0.050 m/pix``
          when there is one.
        * a ROS bag (``.bag``, ``.mcap``, ``.db3``, or a folder holding ``metadata.yaml``):
          the last map on ``/map``, via ``slamq.bags.read_last_map``.
        * a uint8 image array (``HxW``, ``HxWx3``, ``HxWx4``): the image defaults.
        * an int8 nav_msgs/OccupancyGrid array (row 0 = bottom): see
          :func:`from_occupancy_grid`.
        * an :class:`OccupancyMap`: returned as is, unless an argument below changes it.
    unknown_value : int, optional
        Treat pixel == ``unknown_value`` as unknown, and nothing else (no thresholds, no
        205 rule, no alpha). The pixel is the file's grey level before ``negate`` (for
        RGB the rounded channel mean); for OccupancyGrid data it is the grid value (-1 and
        255 are the same). Re-applied to an :class:`OccupancyMap` through
        ``meta["pixels"]``, the loader's pixel array (for a hand-built map: its values).
    resolution : float, optional
        Metres per cell; overrides the YAML's.
    origin : (x, y, yaw), optional
        Overrides the YAML's origin.

    Returns
    -------
    OccupancyMap
        ``meta`` holds: ``kind`` (yaml, image, array, occupancy_grid, or what the bag
        reader says), ``mode``, ``negate``, ``occupied_thresh``, ``free_thresh``, ``yaml``
        and ``image`` paths, ``format``, ``channels``, ``resolution_from``,
        ``unknown_rule`` (which rule made cells unknown), ``warnings`` (the messages also
        issued as :class:`~slamq.errors.MapWarning`) and ``pixels`` (the grey pixel
        array before ``negate``; the same array as ``values`` when nothing changed it).

    Raises
    ------
    MapError
        The message starts with the file (or ``<array>``) and gives the reason:
        missing or unreadable file, truncated or corrupt image, a header claiming more
        cells than the file holds, 16-bit or float pixels, a YAML that does not parse or
        has no ``image``, an unknown mode, resolution <= 0, a map with zero cells, ...

    Examples
    --------
    >>> import numpy as np
    >>> from slamq import load_map
    >>> img = np.array([[0, 205], [254, 255]], np.uint8)     # map_saver's shades
    >>> m = load_map(img)
    >>> m.unknown.tolist(), m.meta["unknown_rule"]
    ([[False, True], [False, False]], 'map_saver: 205 unknown, 0/254/255 known')
    >>> load_map(img, unknown_value=255).unknown.tolist()
    [[False, False], [False, True]]
    """
    warnings_out: list[str] = []
    result = _load(source, unknown_value, resolution, origin, warnings_out)
    for msg in warnings_out:
        warnings.warn(MapWarning(msg), stacklevel=2)
    return result


def _load(
    source: Any,
    unknown_value: int | None,
    resolution: Any,
    origin: Any,
    warnings_out: list[str],
) -> OccupancyMap:
    if isinstance(source, OccupancyMap):
        where = source.source
        res = _check_resolution(resolution, where)
        org = None if origin is None else _check_origin(origin, where)
        return _reapply(source, unknown_value, res, org)

    if isinstance(source, np.ndarray):
        where = "<array>"
        res = _check_resolution(resolution, where)
        org = (0.0, 0.0, 0.0) if origin is None else _check_origin(origin, where)
        if source.dtype == np.int8:
            if source.ndim != 2:
                raise _fail(where, f"an int8 OccupancyGrid array must be 2-D, got "
                                   f"{source.ndim}-D (use from_occupancy_grid for flat data)")
            grid = from_occupancy_grid(source, resolution=res, origin=org, source=where)
            return _reapply(grid, unknown_value, None, None)
        if source.dtype != np.uint8:
            raise _fail(where, f"unsupported array dtype {source.dtype}: expected a uint8 "
                               "image or an int8 OccupancyGrid")
        if source.size == 0:
            raise _fail(where, "the map has zero cells")
        n = None if unknown_value is None else _check_unknown_value(
            unknown_value, where, grid=False)
        grey, alpha, ch = _split_channels(source, where)
        img = _Image(np.ascontiguousarray(grey), alpha, ch, None, "array")
        return _image_map(img, source=where, kind="array", unknown_value=n,
                          resolution=res, origin=org, warnings_out=warnings_out)

    if isinstance(source, (str, os.PathLike)):
        path = Path(os.fspath(source))
        where = str(path)
        res = _check_resolution(resolution, where)
        org = None if origin is None else _check_origin(origin, where)
        _stat(path)  # missing, a broken link or a symlink loop: say which
        if _is_bag(path):
            return _reapply(_load_bag(path), unknown_value, res, org)
        if path.is_dir():
            raise _fail(where, "is a directory (not a ROS 2 bag); use "
                               "slamq.maps.discover_maps to find the maps in a folder")
        if path.suffix.lower() in YAML_SUFFIXES:
            return _load_yaml(path, unknown_value=unknown_value, resolution=res, origin=org,
                              warnings_out=warnings_out)
        n = None if unknown_value is None else _check_unknown_value(
            unknown_value, where, grid=False)
        img = _read_image_file(path)
        return _image_map(img, source=where, kind="image", unknown_value=n, resolution=res,
                          origin=(0.0, 0.0, 0.0) if org is None else org,
                          warnings_out=warnings_out)

    raise MapError(f"<{type(source).__name__}>: cannot load a map from a "
                   f"{type(source).__name__}; expected a path, a numpy array or an OccupancyMap")


# ---------------------------------------------------------------------------------------
# Finding maps in folders
# ---------------------------------------------------------------------------------------


def _resolved(path: Path) -> Path:
    """``path.resolve()``, or the absolute path when it cannot be resolved (a symlink loop)."""
    try:
        return path.resolve()
    except (OSError, RuntimeError):
        return path.absolute()


def _reason(exc: MapError, path: Path) -> str:
    """The reason of a MapError raised for ``path``, without the leading path."""
    msg = str(exc)
    prefix = f"{path}: "
    return msg[len(prefix):] if msg.startswith(prefix) else msg


def _yaml_image_target(path: Path) -> tuple[Path | None, str | None]:
    """(resolved image path or None, problem or None) of a YAML met while searching.

    Returns (None, None) for a YAML that is not a map (no ``image``): it is skipped.
    """
    import yaml

    try:
        if path.stat().st_size > _MAX_YAML_BYTES:
            return None, None
    except OSError:
        pass  # said below
    try:
        raw = _read_regular_file(path, "a map YAML", _MAX_YAML_BYTES)
    except MapError as exc:
        return None, _reason(exc, path)
    try:
        doc = yaml.load(raw, Loader=getattr(yaml, "CSafeLoader", yaml.SafeLoader))
    except (yaml.YAMLError, UnicodeDecodeError) as exc:
        return None, f"unparsable YAML: {_one_line(exc)}"
    if not isinstance(doc, dict) or not isinstance(doc.get("image"), str):
        return None, None
    ref = Path(doc["image"])
    if not ref.is_absolute():
        return path.parent / ref, None
    if ref.is_file():
        return ref, None
    return path.parent / ref.name, None


def discover_maps(paths: Any) -> tuple[list[Path], list[tuple[str, str]]]:
    """Find the maps in files and folders (folders are searched recursively).

    A folder yields every map YAML in it (a YAML with an ``image`` field) and every image
    that no YAML names, so a map saved as YAML + PGM is found once, through its YAML.
    Other YAML files (configs, bag ``metadata.yaml``) are skipped, and so are ROS 2 bag
    folders and hidden folders; a file or bag named explicitly is always kept.

    Parameters
    ----------
    paths : path or iterable of paths

    Returns
    -------
    maps : list of pathlib.Path
        In argument order, each folder's finds sorted; no duplicates.
    problems : list of (str, str)
        ``(path, reason)`` for missing paths, unsupported files, unparsable YAML.

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
            _stat(path)
        except MapError as exc:
            problems.append((str(path), _reason(exc, path)))
            continue
        if path.is_file():
            suffix = path.suffix.lower()
            if suffix in YAML_SUFFIXES or suffix in IMAGE_SUFFIXES or suffix in BAG_SUFFIXES:
                add(path)
            else:
                problems.append((str(path), "not a map file: expected a map YAML, an image "
                                            "(.pgm, .png, ...) or a ROS bag"))
            continue
        if _is_bag(path):
            add(path)
            continue
        yamls: list[Path] = []
        images: list[Path] = []
        for root, dirs, files in os.walk(path):
            rootp = Path(root)
            dirs[:] = sorted(
                d for d in dirs
                if not d.startswith(".") and not (rootp / d / "metadata.yaml").is_file()
            )
            for f in files:
                suffix = Path(f).suffix.lower()
                if suffix in YAML_SUFFIXES:
                    yamls.append(rootp / f)
                elif suffix in IMAGE_SUFFIXES:
                    images.append(rootp / f)
        named: set[Path] = set()
        maps_here: list[Path] = []
        for y in yamls:
            target, problem = _yaml_image_target(y)
            if problem is not None:
                problems.append((str(y), problem))
            elif target is not None:
                maps_here.append(y)
                named.add(_resolved(target))
        maps_here.extend(i for i in images if _resolved(i) not in named)
        for p in sorted(maps_here):
            add(p)
    return found, problems
