"""Image decoding: an own PNM parser, PNG and JPEG header checks before any pixel buffer
exists, OpenCV for the rest. Gives grey + alpha pixels; :mod:`slamq.sources.pixels` turns
them into values and an unknown mask."""

from __future__ import annotations

import math
import re
import struct
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from slamq.sources.files import MAX_CELLS, MAX_IMAGE_BYTES, fail, one_line, read_regular_file

#: zlib cannot compress better than about 1032:1; a PNG header claiming more raw bytes
#: than that allows is corrupt (or a decompression bomb), and is refused before decoding.
_DEFLATE_MAX_RATIO = 1032

_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
_PNG_CHANNELS = {0: 1, 2: 3, 3: 3, 4: 2, 6: 4}
_WHITESPACE = b" \t\r\n\v\f"
_DIGITS = b"0123456789"
_RESOLUTION_COMMENT = re.compile(rb"([0-9]*\.?[0-9]+(?:[eE][-+]?[0-9]+)?)\s*m/pix")

#: rint(s / 3) for every sum of three uint8 channels: the mean, rounded half to even.
_MEAN3_LUT = np.rint(np.arange(3 * 255 + 1, dtype=np.float64) / 3.0).astype(np.uint8)

# ---------------------------------------------------------------------------------------
# Image decoding: own PNM parser, PNG header checks, OpenCV for the rest
# ---------------------------------------------------------------------------------------


@dataclass
class Image:
    grey: np.ndarray  # (H, W) uint8: the pixel, colour channels averaged
    alpha: np.ndarray | None  # (H, W) uint8 or None
    channels: int
    resolution_hint: float | None = None
    format: str = ""


#: Byte classes of an ASCII PNM's samples: 1 a digit, 2 whitespace, 0 anything else.
_ASCII_CLASS = np.zeros(256, np.uint8)
_ASCII_CLASS[list(b"0123456789")] = 1
_ASCII_CLASS[list(b" \t\n\v\f\r")] = 2


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


def _parse_pnm(data: bytes, name: str) -> Image:
    """Netpbm P2/P5 (grey) and P3/P6 (RGB), 8-bit, checked before any allocation."""
    magic = data[:2]
    if magic in (b"P1", b"P4"):
        raise fail(name, "PBM bitmaps (P1/P4) are not supported; save the map as PGM (P5)")
    if magic == b"P7":
        raise fail(name, "PAM (P7) images are not supported; save the map as PGM (P5)")
    ascii_ = magic in (b"P2", b"P3")
    channels = 3 if magic in (b"P3", b"P6") else 1
    kind = "PGM" if channels == 1 else "PPM"
    comments: list[bytes] = []
    fields: list[int] = []
    pos = 2
    while len(fields) < 3:
        pos = _skip_space_and_comments(data, pos, comments)
        if pos >= len(data):
            raise fail(name, f"truncated {kind}: the header ends after {len(fields)} of "
                              "3 fields (width, height, maxval)")
        start = pos
        while pos < len(data) and data[pos] in _DIGITS:
            pos += 1
        if pos == start:
            raise fail(name, f"bad {kind} header: expected a number at byte {start}, "
                              f"found {data[start:start + 1]!r}")
        if pos - start > 12:
            raise fail(name, f"bad {kind} header: number too long at byte {start}")
        fields.append(int(data[start:pos]))
    width, height, maxval = fields
    if width == 0 or height == 0:
        raise fail(name, f"the map has zero cells ({kind} header says {width}x{height})")
    if maxval == 0 or maxval > 65535:
        raise fail(name, f"bad {kind} header: maxval {maxval} is outside 1..65535")
    if maxval > 255:
        raise fail(name, f"16-bit {kind} (maxval {maxval}) is not supported; convert it to "
                          "8 bits ('pnmdepth 255' of netpbm) or to a 16-bit PNG, which slamq "
                          "scales")
    cells = width * height
    if cells > MAX_CELLS:
        raise fail(name, f"{kind} header claims {width}x{height} = {cells} cells, "
                          f"more than the limit of {MAX_CELLS}")
    need = cells * channels
    if pos >= len(data) or data[pos] not in _WHITESPACE:
        if pos >= len(data):
            raise fail(name, f"truncated {kind}: header says {width}x{height} "
                              f"({cells} cells) but the file has no pixel data")
        raise fail(name, f"bad {kind} header: no whitespace after maxval")
    pos += 1
    if not ascii_:
        avail = len(data) - pos
        if avail < need:
            raise fail(name, f"truncated {kind}: header says {width}x{height} "
                              f"({cells} cells, {need} bytes) but the file holds only "
                              f"{avail} bytes of pixel data")
        arr = np.frombuffer(data, dtype=np.uint8, count=need, offset=pos)
    else:
        rest = data[pos:]
        # Every ASCII sample takes at least one digit and one separator.
        if len(rest) < 2 * need - 1:
            raise fail(name, f"truncated {kind}: header says {width}x{height} "
                              f"({cells} cells) but only {len(rest)} bytes follow")
        if b"#" in rest:
            rest = re.sub(rb"#[^\n]*", b" ", rest)
        # Checked before numbers are made, in O(1) bytes per byte of the file: only digits
        # and whitespace, and enough samples (numpy's parser fills a short read with junk).
        kind_of = _ASCII_CLASS[np.frombuffer(rest, np.uint8)]
        if not kind_of.all():
            raise fail(name, f"bad ASCII {kind}: a sample is not a decimal number "
                              "in 0..maxval")
        digit = kind_of == 1
        samples = int(np.count_nonzero(digit[1:] & ~digit[:-1])) + int(digit[0])
        del kind_of, digit
        if samples < need:
            raise fail(name, f"truncated {kind}: header says {width}x{height} "
                              f"({cells} cells, {need} samples) but the file holds "
                              f"only {samples} samples")
        # a long run of digits saturates at 2**63 - 1 and fails the maxval check below
        wide = np.fromstring(rest, dtype=np.int64, sep=" ", count=need)
        if wide.min() < 0:
            raise fail(name, f"bad ASCII {kind}: negative sample")
        top = int(wide.max())
        if top > 65535:  # e.g. a run of digits that saturated the parser
            raise fail(name, f"bad ASCII {kind}: a sample is not a decimal number "
                              "in 0..maxval")
        if top > maxval:
            raise fail(name, f"bad {kind}: sample {top} exceeds maxval {maxval}")
        arr = wide.astype(np.uint8)
    if not ascii_ and maxval < 255:
        top = int(arr.max())
        if top > maxval:
            raise fail(name, f"bad {kind}: sample {top} exceeds maxval {maxval}")
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
    return Image(grey, None, channels, hint, kind)


def _check_png_header(data: bytes, name: str) -> None:
    if len(data) < 33 or data[12:16] != b"IHDR":
        raise fail(name, "truncated or corrupt PNG: no IHDR header")
    width, height = struct.unpack(">II", data[16:24])
    depth, ctype = data[24], data[25]
    if ctype not in _PNG_CHANNELS or depth not in (1, 2, 4, 8, 16):
        raise fail(name, f"corrupt PNG: bit depth {depth}, colour type {ctype}")
    if width == 0 or height == 0:
        raise fail(name, f"the map has zero cells (PNG header says {width}x{height})")
    cells = width * height
    if cells > MAX_CELLS:
        raise fail(name, f"PNG header claims {width}x{height} = {cells} cells, "
                          f"more than the limit of {MAX_CELLS}")
    raw_bytes = height * (1 + (width * _PNG_CHANNELS[ctype] * depth + 7) // 8)
    if raw_bytes > _DEFLATE_MAX_RATIO * len(data) + 4096:
        raise fail(name, f"corrupt or truncated PNG: the header claims {width}x{height} "
                          f"({cells} cells) but the file holds only {len(data)} bytes")
    if data.rfind(b"IEND") < 0:
        raise fail(name, "truncated PNG: the file ends before its IEND chunk")


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
                raise fail(name, f"corrupt or truncated JPEG: the header claims "
                                  f"{width}x{height} ({cells} cells) but the file holds only "
                                  f"{len(data)} bytes")
            break
        pos += 2 + length
    if data.rfind(b"\xff\xd9") < 0:
        raise fail(name, "truncated JPEG: the file ends before its EOI marker")


def scale_16_bit(arr: np.ndarray) -> np.ndarray:
    """16-bit samples to 8 bits, ``v = round(x * 255 / 65535) = (x + 128) // 257`` (exact
    integers; no sample lies half-way), docs/spec.md section 1.

    Examples
    --------
    >>> scale_16_bit(np.array([0, 128, 129, 32896, 65535], np.uint16)).tolist()
    [0, 0, 1, 128, 255]
    """
    return ((arr.astype(np.uint32) + 128) // 257).astype(np.uint8)


#: For the formats whose size slamq reads from the header (GIF, BMP, WebP, TIFF): a header
#: claiming more cells than this many per byte of file is corrupt or a decompression bomb
#: (a real map compresses far less; a 36-byte WebP claimed 16384 x 16384).
MAX_CELLS_PER_BYTE = 4096


def header_size(data: bytes) -> tuple[str, int, int] | None:
    """``(format, width, height)`` from the header of a GIF, BMP, WebP or TIFF image, or
    None for another format (or a header too short to say).

    Examples
    --------
    >>> header_size(b"GIF89a" + (640).to_bytes(2, "little") + (480).to_bytes(2, "little"))
    ('GIF', 640, 480)
    >>> header_size(b"P5 1 1 255 x") is None
    True
    """
    if data[:6] in (b"GIF87a", b"GIF89a") and len(data) >= 10:
        w, h = struct.unpack("<HH", data[6:10])
        return "GIF", w, h
    if data[:2] == b"BM" and len(data) >= 26:
        w, h = struct.unpack("<ii", data[18:26])
        return "BMP", abs(w), abs(h)
    if data[:4] == b"RIFF" and data[8:12] == b"WEBP" and len(data) >= 30:
        chunk = data[12:16]
        if chunk == b"VP8X":
            w = 1 + int.from_bytes(data[24:27], "little")
            h = 1 + int.from_bytes(data[27:30], "little")
            return "WebP", w, h
        if chunk == b"VP8L":
            bits = int.from_bytes(data[21:25], "little")
            return "WebP", 1 + (bits & 0x3FFF), 1 + ((bits >> 14) & 0x3FFF)
        if chunk == b"VP8 ":
            w, h = struct.unpack("<HH", data[26:30])
            return "WebP", w & 0x3FFF, h & 0x3FFF
        return None
    if data[:4] in (b"II*\x00", b"MM\x00*") and len(data) >= 8:
        return _tiff_size(data)
    return None


def _tiff_size(data: bytes) -> tuple[str, int, int] | None:
    """Width and height of a TIFF's first image (tags 256 and 257 of its first IFD)."""
    end = "<" if data[:2] == b"II" else ">"
    (ifd,) = struct.unpack(end + "I", data[4:8])
    if ifd + 2 > len(data):
        return None
    (n,) = struct.unpack(end + "H", data[ifd:ifd + 2])
    dims: dict[int, int] = {}
    for k in range(min(n, 512)):
        at = ifd + 2 + 12 * k
        if at + 12 > len(data):
            break
        tag, typ = struct.unpack(end + "HH", data[at:at + 4])
        if tag in (256, 257):
            fmt = end + ("H" if typ == 3 else "I")
            (dims[tag],) = struct.unpack(fmt, data[at + 8:at + 8 + struct.calcsize(fmt)])
    if 256 in dims and 257 in dims:
        return "TIFF", dims[256], dims[257]
    return None


def _check_other_header(data: bytes, name: str) -> str:
    """Refuse a GIF, BMP, WebP or TIFF whose header claims more cells than the limits allow,
    before OpenCV allocates them; return the format's name."""
    found = header_size(data)
    if found is None:
        return "image"
    fmt, w, h = found
    cells = w * h
    if cells == 0:
        raise fail(name, f"the map has zero cells ({fmt} header says {w}x{h})")
    if cells > MAX_CELLS:
        raise fail(name, f"{fmt} header claims {w}x{h} = {cells} cells, more than the limit "
                          f"of {MAX_CELLS}")
    if cells > MAX_CELLS_PER_BYTE * len(data) + (1 << 20):
        raise fail(name, f"corrupt {fmt} or a decompression bomb: the header claims {w}x{h} "
                          f"({cells} cells) from a file of {len(data)} bytes")
    return fmt


def split_channels(arr: np.ndarray, name: str) -> tuple[np.ndarray, np.ndarray | None, int]:
    """(grey, alpha, channels) of a uint8 image array: colour channels averaged (rint)."""
    if arr.ndim == 2:
        return arr, None, 1
    if arr.ndim != 3 or arr.shape[2] not in (1, 2, 3, 4):
        raise fail(name, f"expected an HxW, HxWx3 or HxWx4 image, got shape {arr.shape}")
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


def decode_image(data: bytes, name: str) -> Image:
    """Decode image bytes (any format) into grey + alpha, or raise MapError naming ``name``."""
    if len(data) == 0:
        raise fail(name, "empty file")
    if data[:1] == b"P" and data[1:2] in b"1234567" and len(data) >= 2:
        return _parse_pnm(data, name)
    fmt = "image"
    if data[:8] == _PNG_SIGNATURE:
        _check_png_header(data, name)
        fmt = "PNG"
    elif data[:3] == b"\xff\xd8\xff":
        _check_jpeg_header(data, name)
        fmt = "JPEG"
    else:
        fmt = _check_other_header(data, name)
    import cv2

    try:
        arr = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), cv2.IMREAD_UNCHANGED)
    except cv2.error as exc:
        raise fail(name, f"cannot decode image: {one_line(exc)}") from None
    if arr is None:
        if fmt == "PNG":
            raise fail(name, "corrupt or truncated PNG: the decoder could not read it")
        raise fail(name, "not a readable image (unknown format, or corrupt data)")
    if arr.dtype == np.uint16:
        arr = scale_16_bit(arr)
        fmt += " (16-bit, scaled)"
    if arr.dtype != np.uint8:
        raise fail(name, f"{arr.dtype} pixels: float images are not supported; save the map "
                          "with 8-bit (or 16-bit) pixels")
    if arr.size == 0:
        raise fail(name, "the map has zero cells")
    grey, alpha, ch = split_channels(arr, name)
    return Image(np.ascontiguousarray(grey), alpha, ch, None, fmt)


def read_image_file(path: Path) -> Image:
    return decode_image(read_regular_file(path, "an image", MAX_IMAGE_BYTES), str(path))
