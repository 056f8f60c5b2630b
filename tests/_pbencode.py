"""A minimal protobuf encoder of Cartographer's pbstream messages, independent of the
decoders under test (slamq.sources.pbstream and pbstream_map)."""

from __future__ import annotations

import gzip
import math
import struct

import numpy as np

from slamq.sources.pbstream import PBSTREAM_MAGIC, UTS_EPOCH_OFFSET_TICKS


def varint(n: int) -> bytes:
    n &= (1 << 64) - 1  # negatives as 10-byte two's complement, as protobuf does
    out = bytearray()
    while True:
        b = n & 0x7F
        n >>= 7
        if n:
            out.append(b | 0x80)
        else:
            out.append(b)
            return bytes(out)


def f_varint(number: int, value: int) -> bytes:
    return varint(number << 3) + varint(value)


def f_double(number: int, value: float) -> bytes:
    return varint(number << 3 | 1) + struct.pack("<d", value)


def f_msg(number: int, payload: bytes) -> bytes:
    return varint(number << 3 | 2) + varint(len(payload)) + payload


def rigid3d(t, q_xyzw, *, skip_zero=True) -> bytes:
    vec = b"".join(f_double(i + 1, v) for i, v in enumerate(t) if v or not skip_zero)
    quat = b"".join(f_double(i + 1, v) for i, v in enumerate(q_xyzw) if v or not skip_zero)
    return f_msg(1, vec) + f_msg(2, quat)


def node(index: int, ticks: int, t, q_xyzw) -> bytes:
    # field order shuffled on purpose: decoders must not depend on it
    return f_msg(5, rigid3d(t, q_xyzw)) + f_varint(1, ticks) + (
        f_varint(7, index) if index else b""
    )


def trajectory(tid, nodes) -> bytes:
    head = f_varint(3, tid) if tid else b""  # proto3: a zero id is left off
    return head + b"".join(f_msg(1, n) for n in nodes)


def pose_graph(trajectories) -> bytes:
    junk_constraint = f_msg(2, f_msg(1, f_varint(1, 0) + f_varint(2, 3)) + f_double(6, 1e5))
    landmark = f_msg(5, f_msg(1, b"lm") + f_msg(2, rigid3d((1, 2, 3), (0, 0, 0, 1))))
    return junk_constraint + b"".join(f_msg(4, t) for t in trajectories) + landmark


def stream(*records: bytes) -> bytes:
    out = struct.pack("<Q", PBSTREAM_MAGIC)
    for r in records:
        z = gzip.compress(r)
        out += struct.pack("<Q", len(z)) + z
    return out


def unix_ticks(seconds: float) -> int:
    return UTS_EPOCH_OFFSET_TICKS + int(round(seconds * 1e7))


def yaw_xyzw(yaw):
    return (0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2))



def f_float(number: int, value: float) -> bytes:
    return varint(number << 3 | 5) + struct.pack("<f", value)


def f_packed(number: int, values) -> bytes:
    return f_msg(number, b"".join(varint(int(v)) for v in values))


# --- trajectories: two of them, the second with one node

NODES0 = [
    # (index, unix seconds, translation, rotation xyzw)
    (0, 1_600_000_000.0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0)),
    (1, 1_600_000_000.1, (0.25, -1.5, 0.0), yaw_xyzw(0.3)),
    (2, 1_600_000_000.2, (1.125, -2.0, 0.0625), yaw_xyzw(-2.9)),
    (5, 1_600_000_000.7, (-3.0, 4.0, 0.0), (0.1, -0.2, 0.3, math.sqrt(1 - 0.14))),
]
NODES1 = [(0, 1_600_000_100.0, (9.0, 9.0, 0.0), yaw_xyzw(1.0))]


def encoded_nodes(spec):
    return [node(i, unix_ticks(s), t, q) for i, s, t, q in spec]


def full_stream(version=2) -> bytes:
    header = f_varint(1, version)
    graph = pose_graph([trajectory(0, encoded_nodes(NODES0)), trajectory(1, encoded_nodes(NODES1))])
    options = f_msg(2, f_msg(1, b"\x0a\x00"))  # AllTrajectoryBuilderOptions: ignored
    submap = f_msg(3, b"\x0a\x04\x08\x00\x10\x00" + b"\x12\x00")
    return stream(header, f_msg(1, graph), options, submap)



# --- submaps (Cartographer's SerializedData.submap and PoseGraph submap poses)

RES = 0.1  # metres per cell of the submaps written here
OCC, FREE = 1, 32767  # cell values of p = 0.9 and p = 0.1 (correspondence cost 0.1, 0.9)


def vec2(x: float, y: float) -> bytes:
    return (b"" if x == 0 else f_double(1, x)) + (b"" if y == 0 else f_double(2, y))


def grid2d(cells: np.ndarray, max_xy: tuple[float, float], box: tuple[int, int, int, int],
           declared: tuple[int, int] | None = None) -> bytes:
    """``cells[y, x]`` (y along -x, x along -y of the local frame), box (min_x, min_y,
    max_x, max_y); ``declared``: other (num_x_cells, num_y_cells) for the limits."""
    ny, nx = cells.shape
    if declared is not None:
        nx, ny = declared
    limits = (f_double(1, RES) + f_msg(2, vec2(*max_xy))
              + f_msg(3, f_varint(1, nx) + f_varint(2, ny)))
    cell_box = (f_varint(1, box[2]) + f_varint(2, box[3]) + f_varint(3, box[0])
                + f_varint(4, box[1]))
    return (f_msg(1, limits) + f_packed(2, cells.ravel()) + f_msg(3, cell_box)
            + f_msg(4, b"") + f_float(6, 0.1) + f_float(7, 0.9))


def submap(tid: int, index: int, local_pose: tuple, grid: bytes) -> bytes:
    sid = (f_varint(1, tid) if tid else b"") + (f_varint(2, index) if index else b"")
    x, y, yaw = local_pose
    return f_msg(3, f_msg(1, sid) + f_msg(2, f_msg(1, rigid3d((x, y, 0), yaw_xyzw(yaw)))
                                          + f_varint(2, 10) + f_msg(4, grid)))


def graph(poses: dict[int, tuple]) -> bytes:
    subs = b"".join(f_msg(2, f_msg(1, rigid3d((x, y, 0), yaw_xyzw(yaw))) + f_varint(2, i))
                    for i, (x, y, yaw) in poses.items())
    return f_msg(1, f_msg(4, subs))


def write(tmp_path, *records: bytes):
    p = tmp_path / "map.pbstream"
    p.write_bytes(stream(f_varint(1, 2), *records))
    return p


def gzip_repeated(parts: list[tuple[bytes, int]]) -> bytes:
    """A gzip member of ``b"".join(data * times for data, times in parts)``, made fast:
    each distinct part is deflated once after a full flush (which resets the compressor,
    so every repetition compresses to the same bytes) and the copies are concatenated.
    1 GiB of zeros takes about 1 MB."""
    import zlib

    c = zlib.compressobj(9, zlib.DEFLATED, -15)
    body = bytearray()
    crc = size = 0
    for data, times in parts:
        if times <= 0:
            continue
        first = c.compress(data) + c.flush(zlib.Z_FULL_FLUSH)
        body += first
        if times > 1:
            again = c.compress(data) + c.flush(zlib.Z_FULL_FLUSH)
            body += again
            if times > 2:
                check = c.compress(data) + c.flush(zlib.Z_FULL_FLUSH)
                assert check == again, "a full flush did not reset the compressor"
                body += again * (times - 2)
        for _ in range(times):
            crc = zlib.crc32(data, crc)
        size += len(data) * times
    body += c.flush()
    return (b"\x1f\x8b\x08\x00\x00\x00\x00\x00\x02\xff" + bytes(body)
            + struct.pack("<II", crc, size & 0xFFFFFFFF))


def raw_stream(*members: bytes) -> bytes:
    """A pbstream of already compressed records."""
    return struct.pack("<Q", PBSTREAM_MAGIC) + b"".join(
        struct.pack("<Q", len(m)) + m for m in members)


#: The decompression bombs of :func:`pbstream_bomb`.
BOMB_SHAPES = ("zeros", "skipped", "declared", "trajectories")


def pbstream_bomb(shape: str) -> bytes:
    """A ~1 MB pbstream whose record inflates to 1 GiB: ``zeros`` (no header, 1 GiB of zero
    bytes), ``skipped`` (a header, then 1,024 fields of 1 MiB that no reader keeps),
    ``declared`` (a pose graph that says it is 1 GiB long), ``trajectories`` (a 200 MiB pose
    graph of 200 trajectories holding only unknown fields, then 824 MiB of other fields)."""
    mib = 1 << 20

    def field(number: int, size: int) -> bytes:  # `size` bytes in all, zeros inside
        head = varint(number << 3 | 2)
        return head + varint(size - len(head) - 3) + bytes(size - len(head) - 3)

    header = gzip.compress(f_varint(1, 2))
    if shape == "zeros":
        return raw_stream(gzip_repeated([(bytes(mib), 1024)]))
    if shape == "skipped":
        return raw_stream(header, gzip_repeated([(field(5, mib), 1024)]))
    if shape == "declared":
        return raw_stream(header, gzip_repeated([(b"\x0a" + varint(1 << 30), 1),
                                                 (bytes(mib), 1024)]))
    if shape != "trajectories":
        raise ValueError(f"no bomb {shape!r}: {BOMB_SHAPES}")
    trajectory = b"\x22" + varint(mib - 4) + field(9, mib - 4)
    return raw_stream(header, gzip_repeated([(b"\x0a" + varint(200 * mib), 1),
                                             (trajectory, 200), (field(5, mib), 824)]))
