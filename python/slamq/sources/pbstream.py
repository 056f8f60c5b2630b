"""Cartographer ``.pbstream`` files: the optimised trajectory node poses, without ROS.

A pbstream is Cartographer's proto stream (cartographer/io/proto_stream.cc): the 8-byte
magic ``0x7b1d1f7b5bf501db`` (little-endian), then records, each a uint64 little-endian
size followed by that many bytes of a gzip-compressed protobuf message. The first record
is a ``SerializationHeader`` (``format_version`` 1 or 2), the second a ``SerializedData``
holding the ``PoseGraph``; submaps, nodes and sensor data follow and are not read here.
(Streams written before the header existed start with the ``PoseGraph`` itself; they are
read too.)

The few fields needed are decoded by hand from the protobuf wire format, so nothing but
the standard library is used. A record is inflated and parsed as a stream (1 MiB at a
time): only the fields a reader needs are kept (trajectory nodes and poses here; submap
grids in :mod:`slamq.sources.pbstream_map`), everything else is skipped as it streams by,
a record inflating past :data:`MAX_RECORD_BYTES` is refused there, and a field declaring
more than that budget is refused before a byte of it is read. A 1 MB file whose record
inflates to 1 GiB thus costs a few MiB of memory, not the budget.

Field numbers, from Cartographer's ``.proto`` files:

======================================  ====================================================
message (file)                          fields read
======================================  ====================================================
SerializationHeader (serialization)     1 format_version (uint32)
SerializedData (serialization)          1 pose_graph (PoseGraph)
PoseGraph (pose_graph)                  4 trajectory (repeated Trajectory)
Trajectory (trajectory)                 3 trajectory_id (int32), 1 node (repeated Node)
Trajectory.Node (trajectory)            7 node_index (int32), 1 timestamp (int64),
                                        5 pose (Rigid3d, tracking frame in the map frame)
Rigid3d (transform)                     1 translation (Vector3d), 2 rotation (Quaterniond)
Vector3d / Quaterniond (transform)      doubles x=1, y=2, z=3 (w=4)
======================================  ====================================================

Timestamps are Cartographer "universal" times: 100 ns ticks since 0001-01-01; they are
converted to Unix seconds (the epoch is 719162 days later). Proto3 leaves zero values off
the wire, so a missing field reads as 0 (a missing rotation as the identity).
"""

from __future__ import annotations

import os
import struct
import zlib
from collections.abc import Iterator
from pathlib import Path
from typing import Any, BinaryIO

import numpy as np

from slamq.errors import TrajectoryError
from slamq.models import Trajectory
from slamq.sources.files import PathLike

__all__ = [
    "PBSTREAM_MAGIC",
    "UTS_EPOCH_OFFSET_TICKS",
    "read_pbstream_poses",
    "read_pbstream_trajectories",
    "read_pbstream_trajectory",
]

#: First eight bytes of a proto stream, as a little-endian uint64.
PBSTREAM_MAGIC = 0x7B1D1F7B5BF501DB
#: Universal ticks (100 ns since 0001-01-01) at the Unix epoch.
UTS_EPOCH_OFFSET_TICKS = 719162 * 24 * 60 * 60 * 10_000_000
#: Universal ticks at the end of year 9999: later (or negative) times are corrupt data
#: (near INT64_MIN they wrapped to plausible positive times).
_MAX_TICKS = 3652059 * 24 * 60 * 60 * 10_000_000

_VARINT, _I64, _LEN, _I32 = 0, 1, 2, 5


class _WireError(ValueError):
    pass


def _varint(buf: memoryview, pos: int) -> tuple[int, int]:
    result = 0
    shift = 0
    while True:
        if pos >= len(buf):
            raise _WireError("truncated varint")
        b = buf[pos]
        pos += 1
        result |= (b & 0x7F) << shift
        if not b & 0x80:
            return result, pos
        shift += 7
        if shift > 63:
            raise _WireError("varint longer than 10 bytes")


def _fields(buf: memoryview) -> Iterator[tuple[int, int, object]]:
    """``(field number, wire type, value)``: int for varints, memoryview otherwise."""
    pos = 0
    end = len(buf)
    while pos < end:
        key, pos = _varint(buf, pos)
        number, wire = key >> 3, key & 7
        if number == 0:
            raise _WireError("field number 0")
        if wire == _VARINT:
            value, pos = _varint(buf, pos)
            yield number, wire, value
        elif wire == _I64:
            if pos + 8 > end:
                raise _WireError("truncated 64-bit field")
            yield number, wire, buf[pos : pos + 8]
            pos += 8
        elif wire == _LEN:
            size, pos = _varint(buf, pos)
            if pos + size > end:
                raise _WireError("truncated length-delimited field")
            yield number, wire, buf[pos : pos + size]
            pos += size
        elif wire == _I32:
            if pos + 4 > end:
                raise _WireError("truncated 32-bit field")
            yield number, wire, buf[pos : pos + 4]
            pos += 4
        else:
            raise _WireError(f"unsupported wire type {wire}")


def _signed(value: int, bits: int = 64) -> int:
    """Two's complement of a varint (int32/int64 negatives are 10-byte varints)."""
    value &= (1 << 64) - 1
    if value >= 1 << 63:
        value -= 1 << 64
    if bits == 32:
        value = (value + (1 << 31)) % (1 << 32) - (1 << 31)
    return value


def _double(wire: int, value: object) -> float:
    if wire != _I64:
        raise _WireError("expected a double (64-bit) field")
    return struct.unpack("<d", value)[0]  # type: ignore[arg-type]


def _doubles(buf: memoryview, names: str, default: tuple[float, ...]) -> list[float]:
    out = list(default)
    for number, wire, value in _fields(buf):
        if 1 <= number <= len(names):
            out[number - 1] = _double(wire, value)
    return out


def _rigid3d(buf: memoryview) -> tuple[list[float], list[float]]:
    """Translation ``[x, y, z]`` and rotation ``[w, x, y, z]`` of a Rigid3d."""
    translation = [0.0, 0.0, 0.0]
    rotation = [1.0, 0.0, 0.0, 0.0]
    for number, wire, value in _fields(buf):
        if wire != _LEN:
            continue
        if number == 1:
            translation = _doubles(value, "xyz", (0.0, 0.0, 0.0))  # type: ignore[arg-type]
        elif number == 2:
            x, y, z, w = _doubles(value, "xyzw", (0.0, 0.0, 0.0, 0.0))  # type: ignore[arg-type]
            rotation = [w, x, y, z]
    return translation, rotation


#: Largest decompressed pbstream record (a PoseGraph of ~2 M nodes); past it a record is a
#: decompression bomb or corrupt (a 1 MB file could inflate to 1 GiB).
MAX_RECORD_BYTES = 256 << 20
#: Largest field kept in memory where a small message belongs (a node, a pose, an id, a
#: grid's limits): a few dozen bytes in Cartographer's files.
SMALL = 1 << 20
#: Inflated bytes made per step: what a record costs in memory besides the fields kept.
_STEP = 1 << 20
_COMPRESSED_STEP = 64 << 10
_BEGIN, _END = -1, -2  # pseudo wire types: a nested message starts / ends


class _Record:
    """One gzip-compressed record, inflated as it is read (``_STEP`` bytes at a time), so
    a record is never held whole: past :data:`MAX_RECORD_BYTES` inflated bytes it is
    refused, whatever was kept of it. ``pos`` is the inflated bytes consumed."""

    def __init__(self, f: BinaryIO, size: int, path: Path) -> None:
        self._f, self._left, self._path = f, size, path
        self._inflater = zlib.decompressobj(wbits=16 + zlib.MAX_WBITS)
        self._buf = b""
        self._off = 0
        self._base = 0  # record offset of self._buf[0]
        self._made = 0  # inflated bytes produced

    @property
    def pos(self) -> int:
        return self._base + self._off

    def _more(self) -> bool:
        """Inflate the next step onto the unread bytes; False at the end of the record."""
        inflater = self._inflater
        while not inflater.eof:
            data = inflater.unconsumed_tail
            if not data:
                if self._left <= 0:
                    return False
                data = self._f.read(min(self._left, _COMPRESSED_STEP))
                self._left -= len(data)
                if not data:
                    return False
            try:
                chunk = inflater.decompress(data, _STEP)
            except zlib.error as exc:
                raise TrajectoryError(
                    f"{self._path}: corrupt pbstream record (gzip: {exc})") from None
            if chunk:
                self._made += len(chunk)
                if self._made > MAX_RECORD_BYTES:
                    raise TrajectoryError(
                        f"{self._path}: a pbstream record inflates past {MAX_RECORD_BYTES} "
                        "bytes (corrupt, or a decompression bomb)")
                rest = self._buf[self._off:]
                self._base += self._off
                self._buf = rest + chunk if rest else chunk
                self._off = 0
                return True
        return False

    def at_end(self) -> bool:
        """True when every inflated byte was consumed and the gzip member is complete."""
        if self._off < len(self._buf) or self._more():
            return False
        if not self._inflater.eof:
            raise TrajectoryError(f"{self._path}: corrupt pbstream record (gzip: truncated)")
        return True

    def _need(self, what: str) -> None:
        """More bytes, or the error: a truncated gzip member, else a truncated ``what``."""
        if not self._more():
            self.at_end()
            raise _WireError(f"truncated {what}")

    def varint(self) -> int:
        buf, off = self._buf, self._off
        if off + 10 > len(buf):  # near the end of the buffer: byte by byte
            result = shift = 0
            while True:
                if self._off >= len(self._buf):
                    self._need("varint")
                b = self._buf[self._off]
                self._off += 1
                result |= (b & 0x7F) << shift
                if not b & 0x80:
                    return result
                shift += 7
                if shift > 63:
                    raise _WireError("varint longer than 10 bytes")
        b = buf[off]
        if b < 0x80:
            self._off = off + 1
            return b
        result = b & 0x7F
        shift = 7
        off += 1
        while True:
            b = buf[off]
            off += 1
            result |= (b & 0x7F) << shift
            if not b & 0x80:
                self._off = off
                return result
            shift += 7
            if shift > 63:
                raise _WireError("varint longer than 10 bytes")

    def read(self, n: int) -> memoryview:
        """The next ``n`` inflated bytes, copied: what is kept never pins a whole step of
        the inflated stream."""
        off = self._off
        if off + n <= len(self._buf):
            self._off = off + n
            return memoryview(self._buf[off:off + n])
        kept = bytearray()
        while len(kept) < n:
            if self._off >= len(self._buf):
                self._need("length-delimited field")
            take = min(n - len(kept), len(self._buf) - self._off)
            kept += memoryview(self._buf)[self._off:self._off + take]
            self._off += take
        return memoryview(kept)

    def skip(self, n: int) -> None:
        """Consume ``n`` bytes without keeping them."""
        while n:
            if self._off >= len(self._buf):
                self._need("length-delimited field")
            take = min(n, len(self._buf) - self._off)
            self._off += take
            n -= take


def _walk(rec: _Record, spec: dict[int, Any]
          ) -> Iterator[tuple[tuple[int, ...], int, Any]]:
    """The fields of a record's message, streamed: ``(path, wire, value)``.

    ``spec`` says what to do with each field number: a dict descends into a
    length-delimited field (``(path, _BEGIN, None)`` and ``(path, _END, None)`` around its
    fields, read with that dict); an int keeps its value (varints and fixed fields;
    length-delimited ones of at most that many bytes, as a memoryview); ``0`` reports a
    length-delimited field without reading it (``value`` None); ``(cap, dict)`` keeps a
    length-delimited field of at most ``cap`` bytes whole (faster to parse in memory) and
    descends into a longer one. Other fields are skipped, never kept.
    """
    # the messages being read, innermost last: (end offset or None, spec, path)
    stack: list[tuple[int | None, dict[int, Any], tuple[int, ...]]] = [(None, spec, ())]
    end, spec, path = stack[-1]
    while True:
        if end is None:
            if rec.at_end():
                return
        elif rec.pos >= end:
            if rec.pos > end:
                raise _WireError("a field runs past the end of its message")
            yield path, _END, None
            stack.pop()
            end, spec, path = stack[-1]
            continue
        key = rec.varint()
        number, wire = key >> 3, key & 7
        if number == 0:
            raise _WireError("field number 0")
        todo = spec.get(number)
        if wire == _LEN:
            size = rec.varint()
            pos = rec.pos
            if end is not None and pos + size > end:
                raise _WireError("truncated length-delimited field")
            if size > MAX_RECORD_BYTES - pos:  # refused before a byte of it is read
                raise _WireError(f"a field of {size} bytes at byte {pos} of its record "
                                 f"runs past the record budget of {MAX_RECORD_BYTES} bytes")
            if isinstance(todo, tuple):  # (cap, spec): kept whole up to cap, else walked
                todo = todo[0] if size <= todo[0] else todo[1]
            if isinstance(todo, dict):
                path = (*path, number)
                end, spec = pos + size, todo
                stack.append((end, spec, path))
                yield path, _BEGIN, None
            elif not todo:
                if todo == 0:
                    yield (*path, number), wire, None
                rec.skip(size)
            elif size > todo:
                raise _WireError(f"a field of {size} bytes where a message of at most "
                                 f"{todo} bytes belongs")
            else:
                yield (*path, number), wire, rec.read(size)
            continue
        if wire == _VARINT:
            value: Any = rec.varint()
        elif wire == _I64:
            value = rec.read(8)
        elif wire == _I32:
            value = rec.read(4)
        else:
            raise _WireError(f"unsupported wire type {wire}")
        if todo is not None:
            yield (*path, number), wire, value


def _records(f: BinaryIO, path: Path) -> Iterator[_Record]:
    """The records of a pbstream, each streamed (see :class:`_Record`)."""
    file_size = os.fstat(f.fileno()).st_size
    head = f.read(8)
    if len(head) < 8 or struct.unpack("<Q", head)[0] != PBSTREAM_MAGIC:
        raise TrajectoryError(f"{path}: not a Cartographer pbstream (bad magic number)")
    start = 8
    while True:
        f.seek(start)
        size_bytes = f.read(8)
        if not size_bytes:
            return
        if len(size_bytes) < 8:
            raise TrajectoryError(f"{path}: truncated pbstream (partial record size)")
        (size,) = struct.unpack("<Q", size_bytes)
        left = file_size - start - 8
        if size > left:  # checked before reading: a corrupt size must not allocate it
            raise TrajectoryError(
                f"{path}: truncated pbstream (record of {size} bytes, {max(left, 0)} left)"
            )
        start += 8 + size
        yield _Record(f, size, path)


#: A trajectory's fields: 3 trajectory_id (a varint), 1 node (kept: a few dozen bytes)
_TRAJECTORY = (16 << 20, {3: 0, 1: SMALL})  # kept whole up to 16 MiB (~150,000 nodes)


def _node(buf: memoryview) -> tuple[int, int, list, list]:
    index, stamp = 0, 0
    translation, rotation = [0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]
    for n, w, v in _fields(buf):
        if n == 7 and w == _VARINT:
            index = _signed(v, 32)  # type: ignore[arg-type]
        elif n == 1 and w == _VARINT:
            stamp = _signed(v)  # type: ignore[arg-type]
        elif n == 5 and w == _LEN:
            translation, rotation = _rigid3d(v)  # type: ignore[arg-type]
    return index, stamp, translation, rotation


def _trajectories(events: Iterator[tuple[tuple[int, ...], int, Any]],
                  at: tuple[int, ...]) -> list[tuple[int | None, list]]:
    """``(trajectory_id or None, nodes)`` of every trajectory message at path ``at``."""
    raw: list[tuple[int | None, list]] = []
    tid: int | None = None
    nodes: list = []
    node_at, id_at = (*at, 1), (*at, 3)
    for where, wire, value in events:
        if where == node_at:
            if wire == _LEN:
                nodes.append(_node(value))
        elif where == at:
            if wire == _BEGIN:
                tid, nodes = None, []
            elif wire == _END:
                raw.append((tid, nodes))
            elif wire == _LEN:  # a trajectory kept whole
                raw.append(_trajectory(value))
        elif where == id_at and wire == _VARINT:
            tid = _signed(value, 32)
    return raw


def _trajectory(buf: memoryview) -> tuple[int | None, list]:
    """``(trajectory_id or None, nodes)`` of a Trajectory message held in memory."""
    tid: int | None = None
    nodes = []
    for number, wire, value in _fields(buf):
        if number == 3 and wire == _VARINT:
            tid = _signed(value, 32)  # type: ignore[arg-type]
        elif number == 1 and wire == _LEN:
            nodes.append(_node(value))  # type: ignore[arg-type]
    return tid, nodes


def _pose_graph_trajectories(path: Path) -> list[tuple[int | None, list]]:
    """The trajectories of a pbstream's PoseGraph, streamed: only nodes are kept."""
    with open(path, "rb") as f:
        records = _records(f, path)
        first = next(records, None)
        if first is None:
            raise TrajectoryError(f"{path}: empty pbstream (no records)")
        # the header (only field 1, a varint), or a legacy stream's PoseGraph: its
        # trajectories are read on the way, and dropped if it is a header after all
        top: list[tuple[int, int, Any]] = []
        raw = _trajectories(_noting_top(_walk(first, {1: 0, 4: _TRAJECTORY}), top), (4,))
        is_header = bool(top) and all(n == 1 and wire == _VARINT for n, wire, _ in top)
        if not is_header:
            return raw  # legacy: the PoseGraph comes first
        version = top[0][2]
        if version not in (1, 2):
            raise TrajectoryError(
                f"{path}: unsupported pbstream format_version {version} (1 and 2 are read)"
            )
        second = next(records, None)
        if second is None:
            raise TrajectoryError(f"{path}: pbstream has a header but no PoseGraph")
        stream = _walk(second, {1: {4: _TRAJECTORY}})
        for where, wire, _ in stream:
            if where == (1,) and wire == _BEGIN:  # the first pose_graph field only
                return _trajectories(_until_end(stream, (1,)), (1, 4))
        raise TrajectoryError(
            f"{path}: the record after the header is not a PoseGraph (stream order corrupt)"
        )


def _noting_top(stream: Iterator[tuple[tuple[int, ...], int, Any]],
                top: list[tuple[int, int, Any]]
                ) -> Iterator[tuple[tuple[int, ...], int, Any]]:
    """``stream`` passed on, noting each top-level field ``(number, wire, value)``."""
    for where, wire, value in stream:
        if len(where) == 1 and wire != _END:
            top.append((where[0], _LEN if wire == _BEGIN else wire, value))
        yield where, wire, value


def _until_end(stream: Iterator[tuple[tuple[int, ...], int, Any]], at: tuple[int, ...]
               ) -> Iterator[tuple[tuple[int, ...], int, Any]]:
    """The events of the message begun at ``at``, up to its end (the rest unread)."""
    for where, wire, value in stream:
        if where == at and wire == _END:
            return
        yield where, wire, value


def read_pbstream_poses(
    path: PathLike,
) -> dict[int, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
    """Every trajectory's nodes: ``{id: (node_index, ticks, positions, wxyz)}``.

    ``node_index`` (N,) int64, ``ticks`` (N,) int64 universal time (100 ns since
    0001-01-01), ``positions`` (N, 3), ``wxyz`` (N, 4), in the stream's node order.

    Examples
    --------
    >>> poses = read_pbstream_poses("map.pbstream")  # doctest: +SKIP
    >>> sorted(poses)  # doctest: +SKIP
    [0]
    """
    p = Path(path)
    if not p.is_file():
        raise TrajectoryError(f"{p}: no such file")
    try:
        raw = _pose_graph_trajectories(p)
    except _WireError as exc:
        raise TrajectoryError(f"{p}: corrupt pbstream ({exc})") from None
    # Old (proto2) pose graphs have no trajectory_id: the list index is the id. In proto3 a
    # zero id is left off the wire, so an absent id means 0 when the others are present.
    legacy = all(tid is None for tid, _ in raw)
    out: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = {}
    for i, (tid, nodes) in enumerate(raw):
        key = i if legacy else (tid or 0)
        if key in out:
            raise TrajectoryError(f"{p}: trajectory id {key} appears twice in the pose graph")
        out[key] = (
            np.array([n[0] for n in nodes], dtype=np.int64),
            np.array([n[1] for n in nodes], dtype=np.int64),
            np.array([n[2] for n in nodes], dtype=np.float64).reshape(-1, 3),
            np.array([n[3] for n in nodes], dtype=np.float64).reshape(-1, 4),
        )
    return out


def _to_trajectory(
    p: Path, tid: int, poses: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]
) -> Trajectory:

    _, ticks, pos, rot = poses
    if len(ticks) == 0:
        raise TrajectoryError(f"{p}: trajectory {tid} has no nodes")
    if ticks.min() < 0 or ticks.max() > _MAX_TICKS:
        bad = int(ticks.min()) if ticks.min() < 0 else int(ticks.max())
        raise TrajectoryError(f"{p}: trajectory {tid}: node time {bad} is not a universal "
                              "time (100 ns ticks since year 1, up to year 9999)")
    order = np.argsort(ticks, kind="stable")
    # exact integer offset first, then one division: Unix seconds
    seconds = (ticks[order] - UTS_EPOCH_OFFSET_TICKS).astype(np.float64) / 1e7
    return Trajectory(seconds, pos[order], rot[order], source=f"{p}#trajectory{tid}")


def read_pbstream_trajectories(path: PathLike) -> dict[int, Trajectory]:
    """Every trajectory of a pbstream, by trajectory id (empty trajectories left out).

    Examples
    --------
    >>> trajs = read_pbstream_trajectories("map.pbstream")  # doctest: +SKIP
    >>> {k: len(v) for k, v in trajs.items()}  # doctest: +SKIP
    {0: 1843}
    """
    p = Path(path)
    return {
        tid: _to_trajectory(p, tid, poses)
        for tid, poses in sorted(read_pbstream_poses(p).items())
        if len(poses[1])
    }


def read_pbstream_trajectory(path: PathLike, trajectory_id: int = 0) -> Trajectory:
    """The node poses of one trajectory of a Cartographer ``.pbstream`` (global frame).

    Parameters
    ----------
    path : path
        A ``.pbstream`` file (``cartographer_node`` ``/write_state`` or
        ``cartographer_offline_node`` output).
    trajectory_id : int, default 0
        Which trajectory.

    Returns
    -------
    slamq.Trajectory
        One pose per trajectory node: the optimised pose of the tracking frame in the map
        frame, at the node's time (Unix seconds), sorted by time.

    Raises
    ------
    TrajectoryError
        Not a pbstream, truncated or corrupt, unknown trajectory id (the message lists the
        ids), no nodes.

    Examples
    --------
    >>> traj = read_pbstream_trajectory("map.pbstream")  # doctest: +SKIP
    >>> traj.positions.shape  # doctest: +SKIP
    (1843, 3)
    >>> read_pbstream_trajectory("missing.pbstream")
    Traceback (most recent call last):
    ...
    slamq.errors.TrajectoryError: missing.pbstream: no such file
    """
    p = Path(path)
    poses = read_pbstream_poses(p)
    if trajectory_id not in poses:
        ids = ", ".join(str(k) for k in sorted(poses)) or "none"
        raise TrajectoryError(f"{p}: no trajectory {trajectory_id} (trajectories: {ids})")
    return _to_trajectory(p, trajectory_id, poses[trajectory_id])
