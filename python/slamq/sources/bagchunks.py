"""Compressed bag chunks checked before ``rosbags`` inflates them (decompression bombs).

``rosbags`` inflates a whole ROS1 chunk (bz2, lz4) or MCAP chunk (zstd, lz4) in one call and
compares the size afterwards, so a few KB of compressed zeros become gigabytes first. Before a
bag is opened, :func:`check_compressed_chunks` walks its records (headers only, seeking over
the data of uncompressed chunks), refuses a chunk that declares more than
:data:`MAX_CHUNK_BYTES`, and inflates each compressed chunk as a stream, 1 MiB at a time,
refusing it as soon as it exceeds what it declared. Peak memory is about 2 MiB whatever the
chunk claims; a compressed bag is inflated twice (once here, once by ``rosbags``).

ROS 2 bags compressed by rosbag2 (``compression_format: zstd`` in ``metadata.yaml``) are
checked the same way: in ``message`` mode every message of every storage file is inflated as
a stream and may inflate to at most :data:`MAX_CHUNK_BYTES` (rosbags inflates each one
whole); in ``file`` mode ``rosbags`` inflates each storage file to a temporary folder when
the bag is opened, so each is first inflated as a stream here and may inflate to at most
:data:`MAX_FILE_BYTES` and the temporary folder's free space less 1 GiB.
"""

from __future__ import annotations

import bz2
import struct
from collections.abc import Callable
from pathlib import Path
from typing import Any, BinaryIO

from slamq.errors import BagError
from slamq.sources.files import MAX_CELLS

__all__ = ["MAX_CHUNK_BYTES", "MAX_FILE_BYTES", "check_compressed_chunks"]

#: A chunk may inflate to at most this: one OccupancyGrid of the largest map slamq accepts
#: (2^30 cells) and 1 MiB of other messages.
MAX_CHUNK_BYTES = MAX_CELLS + (1 << 20)

#: A file-compressed ROS 2 storage file may inflate to at most this (rosbags writes it to a
#: temporary folder before reading a message).
MAX_FILE_BYTES = 64 << 30

_STEP = 1 << 20
_ROS1_MAGIC = b"#ROSBAG V2.0\n"
_MCAP_MAGIC = b"\x89MCAP0\r\n"


def _decompressor(kind: str) -> Any:
    """A streaming decompressor (``decompress(data, max_length)``, ``needs_input``)."""
    if kind == "bz2":
        return bz2.BZ2Decompressor()
    if kind == "lz4":
        from lz4.frame import LZ4FrameDecompressor  # a dependency of rosbags

        return LZ4FrameDecompressor()
    if kind == "zstd":
        try:
            from compression import zstd  # Python 3.14
        except ImportError:
            from backports import zstd  # a dependency of rosbags before 3.14
        return zstd.ZstdDecompressor()
    return None  # an unknown compression: rosbags names it


def _inflate_bounded(fh: BinaryIO, length: int, kind: str, limit: int,
                     fail: Callable[[str], BagError]) -> None:
    """Inflate ``length`` bytes of ``fh`` as ``kind``, 1 MiB of input and of output at a
    time, discarding the output; raise ``fail(reason)`` past ``limit`` bytes."""
    d = _decompressor(kind)
    if d is None:
        fh.seek(length, 1)
        return
    total, left, pending = 0, length, b""
    try:
        while left > 0 or pending:
            if pending:
                block, pending = pending, b""
            else:
                block = fh.read(min(_STEP, left))
                if not block:
                    return  # truncated: rosbags says so
                left -= len(block)
            out = d.decompress(block, _STEP)
            total += len(out)
            while total <= limit and not d.eof and not d.needs_input:
                out = d.decompress(b"", _STEP)
                if not out:
                    break
                total += len(out)
            if total > limit:
                raise fail(f"inflates to more than {limit} bytes")
            if d.eof:  # concatenated streams or frames: bz2 and zstd read them all
                pending = d.unused_data
                d = _decompressor(kind)
    except BagError:
        raise
    except Exception:  # noqa: BLE001, S110 - corrupt data (bz2, lz4 and zstd raise their own
        return  # types): rosbags reports it when it reads the chunk


def _bomb(where: str, declared: int) -> Callable[[str], BagError]:
    return lambda reason: BagError(f"{where} {reason}: it declares {declared} (corrupt, or a "
                                   "decompression bomb)")


def _ros1_fields(header: bytes) -> dict[bytes, bytes]:
    fields, pos = {}, 0
    while pos + 4 <= len(header):
        (n,) = struct.unpack_from("<I", header, pos)
        field = header[pos + 4: pos + 4 + n]
        pos += 4 + n
        name, sep, value = field.partition(b"=")
        if sep:
            fields[name] = value
    return fields


def _check_ros1(path: Path, fh: BinaryIO, size: int) -> None:
    pos = len(_ROS1_MAGIC)
    while pos + 4 <= size:
        fh.seek(pos)
        head = fh.read(4)
        (hlen,) = struct.unpack("<I", head)
        if pos + 8 + hlen > size:
            return  # truncated: rosbags says so
        fields = _ros1_fields(fh.read(hlen))
        (dlen,) = struct.unpack("<I", fh.read(4))
        data_at = pos + 8 + hlen
        if fields.get(b"op") == b"\x05":  # a chunk
            compression = fields.get(b"compression", b"none").decode("latin-1")
            declared = int.from_bytes(fields.get(b"size", b"")[:4], "little")
            where = f"{path}: ROS1 chunk at byte {pos}"
            if declared > MAX_CHUNK_BYTES:
                raise BagError(f"{where} declares {declared} bytes, more than the limit of "
                               f"{MAX_CHUNK_BYTES}")
            if compression != "none":
                _inflate_bounded(fh, min(dlen, size - data_at), compression, declared,
                                 _bomb(f"{where} ({compression})", declared))
        pos = data_at + dlen


def _check_mcap(path: Path, fh: BinaryIO, size: int) -> None:
    pos = len(_MCAP_MAGIC)
    while pos + 9 <= size:
        fh.seek(pos)
        op, length = struct.unpack("<BQ", fh.read(9))
        body = pos + 9
        if op == 0x02 or body + length > size:  # the footer, or truncated
            return
        if op == 0x06:  # a chunk
            _, _, declared, _, clen = struct.unpack("<QQQII", fh.read(32))
            compression = fh.read(min(clen, 64)).decode("latin-1", "replace")
            fh.seek(body + 32 + clen)
            (rlen,) = struct.unpack("<Q", fh.read(8))
            where = f"{path}: MCAP chunk at byte {pos}"
            if declared > MAX_CHUNK_BYTES:
                raise BagError(f"{where} declares {declared} bytes, more than the limit of "
                               f"{MAX_CHUNK_BYTES}")
            if compression:
                _inflate_bounded(fh, min(rlen, size - fh.tell()), compression, declared,
                                 _bomb(f"{where} ({compression})", declared))
        pos = body + length


def check_compressed_chunks(bag: Path) -> None:
    """Raise :class:`~slamq.errors.BagError` naming the bag and the chunk when a ROS1 or MCAP
    chunk declares more than :data:`MAX_CHUNK_BYTES` or inflates past what it declares.

    A ROS 2 folder has each of its ``.mcap`` files checked, and, when its ``metadata.yaml``
    says rosbag2 compressed it with zstd, every message (``message`` mode, at most
    :data:`MAX_CHUNK_BYTES` each) or every storage file (``file`` mode, at most
    :data:`MAX_FILE_BYTES` and the temporary folder's free space less 1 GiB). Anything else
    (a truncated or corrupt bag, an uncompressed sqlite3 bag) passes unchanged, for
    ``rosbags`` to judge.

    Examples
    --------
    >>> import bz2, pathlib, struct, tempfile
    >>> def field(k, v): return struct.pack("<I", len(k) + 1 + len(v)) + k + b"=" + v
    >>> hdr = field(b"op", b"\\x05") + field(b"compression", b"bz2") + field(b"size",
    ...                                                                    struct.pack("<I", 10))
    >>> data = bz2.compress(bytes(1 << 20))       # 1 MiB of zeros in 46 bytes
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "bomb.bag"
    >>> _ = p.write_bytes(b"#ROSBAG V2.0\\n" + struct.pack("<I", len(hdr)) + hdr
    ...                   + struct.pack("<I", len(data)) + data)
    >>> check_compressed_chunks(p)
    Traceback (most recent call last):
    ...
    slamq.errors.BagError: /.../bomb.bag: ROS1 chunk at byte 13 (bz2) inflates to more than 10 ...
    """
    if bag.is_dir():
        _check_rosbag2_compression(bag)
    paths = sorted(bag.glob("*.mcap")) if bag.is_dir() else [bag]
    for p in paths:
        try:
            fh = p.open("rb")
        except OSError:
            continue  # rosbags names the file and the reason
        with fh:
            try:
                size = p.stat().st_size
                magic = fh.read(len(_MCAP_MAGIC))
                if magic.startswith(_ROS1_MAGIC[:8]) and fh.read(5) == _ROS1_MAGIC[8:]:
                    _check_ros1(p, fh, size)
                elif magic == _MCAP_MAGIC:
                    _check_mcap(p, fh, size)
            except (OSError, struct.error):
                continue  # truncated or unreadable: rosbags names the reason


def _check_rosbag2_compression(folder: Path) -> None:
    """The rosbag2 ``compression_mode`` checks of :func:`check_compressed_chunks`."""
    import io
    import shutil
    import sqlite3
    import tempfile

    from slamq.sources.files import MAX_YAML_BYTES, load_yaml_safely

    meta = folder / "metadata.yaml"
    try:
        if meta.stat().st_size > MAX_YAML_BYTES:
            return  # rosbags names what is wrong with it
        doc = load_yaml_safely(meta.read_bytes(), meta)
        info = doc["rosbag2_bagfile_information"]
        mode = str(info.get("compression_mode") or "").lower()
        fmt = str(info.get("compression_format") or "").lower()
        files = [folder / Path(str(p)).name for p in info.get("relative_file_paths") or []]
    except Exception:  # noqa: BLE001, S110 - unreadable metadata: rosbags says why
        return
    if mode not in ("message", "file") or fmt != "zstd":
        return  # not compressed, or a format rosbags refuses itself
    for path in files:
        if mode == "file":
            try:
                free = shutil.disk_usage(tempfile.gettempdir()).free - (1 << 30)
                size = path.stat().st_size
                fh = path.open("rb")
            except OSError:
                continue  # rosbags names the file and the reason
            limit = max(0, min(MAX_FILE_BYTES, free))
            with fh:
                _inflate_bounded(fh, size, "zstd", limit, _file_bomb(path, limit))
            continue
        if not path.is_file():
            continue
        try:
            db = sqlite3.connect(path.absolute().as_uri() + "?mode=ro", uri=True)
        except sqlite3.Error:
            continue
        try:
            rows = db.execute("SELECT id, data FROM messages")
            for row_id, data in rows:
                if not isinstance(data, (bytes, memoryview)):
                    continue
                _inflate_bounded(io.BytesIO(data), len(data), "zstd", MAX_CHUNK_BYTES,
                                 _message_bomb(path, row_id))
        except sqlite3.Error:
            pass  # not a rosbag2 database: rosbags names the reason
        finally:
            db.close()


def _message_bomb(path: Path, row_id: Any) -> Callable[[str], BagError]:
    return lambda reason: BagError(
        f"{path}: message {row_id} (zstd) {reason}, the limit for one message (corrupt, or "
        "a decompression bomb)")


def _file_bomb(path: Path, limit: int) -> Callable[[str], BagError]:
    return lambda reason: BagError(
        f"{path}: zstd-compressed storage file {reason}: at most {MAX_FILE_BYTES} bytes and "
        f"the temporary folder's free space less 1 GiB ({limit} bytes) are allowed (corrupt, "
        "or a decompression bomb)")
