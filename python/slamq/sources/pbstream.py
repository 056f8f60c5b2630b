"""Cartographer ``.pbstream`` files: the optimised trajectory node poses, without ROS.

A pbstream is Cartographer's proto stream (cartographer/io/proto_stream.cc): the 8-byte
magic ``0x7b1d1f7b5bf501db`` (little-endian), then records, each a uint64 little-endian
size followed by that many bytes of a gzip-compressed protobuf message. The first record
is a ``SerializationHeader`` (``format_version`` 1 or 2), the second a ``SerializedData``
holding the ``PoseGraph``; submaps, nodes and sensor data follow and are not read here.
(Streams written before the header existed start with the ``PoseGraph`` itself; they are
read too.)

The few fields needed are decoded by hand from the protobuf wire format, so nothing but
the standard library is used. Field numbers, from Cartographer's ``.proto`` files:

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
from typing import BinaryIO

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


def _trajectory(buf: memoryview) -> tuple[int | None, list[tuple[int, int, list, list]]]:
    traj_id: int | None = None
    nodes = []
    for number, wire, value in _fields(buf):
        if number == 3 and wire == _VARINT:
            traj_id = _signed(value, 32)  # type: ignore[arg-type]
        elif number == 1 and wire == _LEN:
            index, stamp = 0, 0
            translation, rotation = [0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]
            for n, w, v in _fields(value):  # type: ignore[arg-type]
                if n == 7 and w == _VARINT:
                    index = _signed(v, 32)  # type: ignore[arg-type]
                elif n == 1 and w == _VARINT:
                    stamp = _signed(v)  # type: ignore[arg-type]
                elif n == 5 and w == _LEN:
                    translation, rotation = _rigid3d(v)  # type: ignore[arg-type]
            nodes.append((index, stamp, translation, rotation))
    return traj_id, nodes


def _records(f: BinaryIO, path: Path) -> Iterator[bytes]:
    file_size = os.fstat(f.fileno()).st_size
    head = f.read(8)
    if len(head) < 8 or struct.unpack("<Q", head)[0] != PBSTREAM_MAGIC:
        raise TrajectoryError(f"{path}: not a Cartographer pbstream (bad magic number)")
    while True:
        size_bytes = f.read(8)
        if not size_bytes:
            return
        if len(size_bytes) < 8:
            raise TrajectoryError(f"{path}: truncated pbstream (partial record size)")
        (size,) = struct.unpack("<Q", size_bytes)
        left = file_size - f.tell()
        if size > left:  # checked before reading: a corrupt size must not allocate it
            raise TrajectoryError(
                f"{path}: truncated pbstream (record of {size} bytes, {max(left, 0)} left)"
            )
        data = f.read(size)
        yield _gunzip(data, path)


#: Largest decompressed pbstream record (a PoseGraph of ~2 M nodes); past it a record is a
#: decompression bomb or corrupt (a 1 MB file could inflate to 1 GiB).
MAX_RECORD_BYTES = 256 << 20


def _gunzip(data: bytes, path: Path) -> bytes:
    """One gzip member, refused past :data:`MAX_RECORD_BYTES` before inflating further."""
    inflater = zlib.decompressobj(wbits=16 + zlib.MAX_WBITS)
    try:
        out = inflater.decompress(data, MAX_RECORD_BYTES + 1)
        if len(out) > MAX_RECORD_BYTES:
            raise TrajectoryError(f"{path}: a pbstream record inflates past "
                                  f"{MAX_RECORD_BYTES} bytes (corrupt, or a decompression bomb)")
        if not inflater.eof:
            raise TrajectoryError(f"{path}: corrupt pbstream record (gzip: truncated)")
    except zlib.error as exc:
        raise TrajectoryError(f"{path}: corrupt pbstream record (gzip: {exc})") from None
    return out


def _pose_graph(path: Path) -> memoryview:
    """The serialized PoseGraph message of a pbstream."""
    with open(path, "rb") as f:
        records = _records(f, path)
        first = next(records, None)
        if first is None:
            raise TrajectoryError(f"{path}: empty pbstream (no records)")
        fields = list(_fields(memoryview(first)))
        is_header = bool(fields) and all(n == 1 and w == _VARINT for n, w, _ in fields)
        if not is_header:
            return memoryview(first)  # legacy stream: the PoseGraph comes first
        version = fields[0][2]
        if version not in (1, 2):
            raise TrajectoryError(
                f"{path}: unsupported pbstream format_version {version} (1 and 2 are read)"
            )
        second = next(records, None)
        if second is None:
            raise TrajectoryError(f"{path}: pbstream has a header but no PoseGraph")
        for number, wire, value in _fields(memoryview(second)):
            if number == 1 and wire == _LEN:
                return value  # type: ignore[return-value]
        raise TrajectoryError(
            f"{path}: the record after the header is not a PoseGraph (stream order corrupt)"
        )


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
        graph = _pose_graph(p)
        raw = [_trajectory(v) for n, w, v in _fields(graph) if n == 4 and w == _LEN]
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
