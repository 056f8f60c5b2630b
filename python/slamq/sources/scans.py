"""A planar laser's scans from a recording, as :class:`slamq.models.Scans` (the data a map
is scored against in docs/spec.md section 7b).

:func:`load_scans` reads:

* **CARMEN logs** (``.clf`` / ``.log``, plain or gzip) through
  :class:`slamq.sources.carmen.CarmenLog`: one laser's scans (``FLASER``, ``RAWLASER1``,
  ``ROBOTLASER1`` for the front laser), their timestamps, beam geometry and the laser's
  offset on the robot.
* **MRPT rawlogs** (``.rawlog``, plain or gzip) of 2D range scans, in both forms MRPT
  writes: action + sensory-frame pairs (``CActionCollection`` / ``CSensoryFrame``, the form
  ``slamq.synth.writers`` writes and ``slamq run``'s MRPT programs read) and observations
  alone. Read without MRPT from its serialization (``CObservation2DRangeScan`` versions 4
  to 8, the sensor pose a ``CPose3D`` of version 1 to 3, ``CActionRobotMovement2D`` of
  versions 4 to 7 with odometry, ``CObservationOdometry``); any other class stops the
  reader with an error naming it, as its size cannot be known without its format. Beam
  ``i`` of ``N`` lies at ``-aperture / 2 + i * aperture / (N - 1)`` (``rightToLeft``; the
  other way round otherwise); an invalid beam has no return. Timestamps are MRPT's 100 ns
  ticks since 1601 turned into Unix seconds.
* **ROS bags** (``.bag``, ``.db3``, ``.mcap`` or a ROS 2 bag folder; the ``bags`` extra)
  with ``sensor_msgs/LaserScan`` messages, read by the walk of
  :mod:`slamq.sources.bag_scans` (``slamq run``'s ``bag:`` sequences read the same): the
  header stamps (the bag time when zero), the beams ``angle_min + i * angle_increment``,
  a range valid when ``range_min < r < range_max``; the laser's offset on the robot from
  the first transform on ``/tf_static`` (else ``/tf``) between the robot's frame (the
  child frame of the bag's only ``nav_msgs/Odometry`` topic) and the scans' frame, in
  either direction; else from the first one whose child is the scans' frame (one hop: its
  parent is taken as the robot); else zero.

One beam layout for all scans (:class:`~slamq.models.Scans` holds one): a log whose scans
change their number of beams, field of view or laser offset (by more than
:data:`OFFSET_TOL`) is refused, naming the first scan that differs; the first scan's layout
is the recording's. Scans whose stamps run backwards (the Intel log's do, 631 times) are
put in time order, as trajectories are (``slamq.load_trajectory`` sorts them too).
"""

from __future__ import annotations

import gzip
import math
import struct
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from slamq.errors import SequenceError
from slamq.models.scans import Scans
from slamq.sources.carmen import CarmenLog, is_carmen, stat_recording
from slamq.sources.files import PathLike, is_bag

__all__ = ["RAWLOG_SUFFIXES", "load_scans", "read_rawlog_scans"]

#: File names read as MRPT rawlogs (``.gz`` too; gzip is recognised by its magic bytes).
RAWLOG_SUFFIXES = (".rawlog", ".rawlog.gz")
#: MRPT ``TTimeStamp`` of the Unix epoch (100 ns ticks since 1601-01-01 UTC).
_EPOCH_TICKS = 116_444_736_000_000_000
#: Scans whose laser offsets differ by less than this (metres, radians) share one layout
#: (a CARMEN ``ROBOTLASER`` line gives the offset as two poses rounded to the millimetre).
OFFSET_TOL = 2e-3
#: The end-of-object flag of MRPT's serialization.
_END = 0x88


def load_scans(path: PathLike, *, laser: str = "front", topic: str | None = None,
               max_scans: int | None = None) -> Scans:
    """The laser scans of a recording: a CARMEN log, an MRPT rawlog or a ROS bag.

    Parameters
    ----------
    path : path
        ``.clf`` / ``.log`` (CARMEN), ``.rawlog`` (MRPT), ``.bag`` / ``.db3`` / ``.mcap`` or
        a ROS 2 bag folder; CARMEN logs and rawlogs may be gzip-compressed.
    laser : {"front", "rear"}, default "front"
        A CARMEN log's laser (:data:`slamq.sources.carmen.LASERS`); for a rawlog, the
        sensor label of the scans to read when it is not "front" or "rear" (default: the
        first 2D scan's label).
    topic : str, optional
        A bag's ``LaserScan`` topic (default: the only one, else ``/scan``).
    max_scans : int, optional
        Stop after this many scans (a cut of the recording's head), at least 1.

    Returns
    -------
    Scans
        ``source`` is the file; ``meta`` has ``format`` and ``reordered`` (how many scans
        were put back in time order).

    Raises
    ------
    slamq.SequenceError
        Not a recording slamq reads, a malformed record (the file, and the line or byte
        offset, are named), no scans, or scans of more than one beam layout.
    slamq.BagError
        A bag that cannot be read or holds no ``LaserScan`` topic, a scan with no beams or
        whose ``range_max`` is not finite and > 0 (the bag, topic and scan are named).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "a.clf"
    >>> _ = p.write_text("FLASER 3 1.0 4.0 2.5 1 2 0 1 2 0 10.75 h 0.25\\n"
    ...                  "FLASER 3 1.0 1.0 90.0 1 2 0 1 2 0 10.85 h 0.35\\n")
    >>> s = load_scans(p)
    >>> s
    Scans('...a.clf', 2 scans x 3 beams, max_range=80)
    >>> s.angles.round(4).tolist(), s.ranges[1].tolist()
    ([-1.5708, 0.0, 1.5708], [1.0, 1.0, inf])
    """
    p = Path(path)
    if max_scans is not None and (isinstance(max_scans, bool) or int(max_scans) < 1):
        raise SequenceError(f"{p}: max_scans must be an integer >= 1 (a Scans holds at "
                            f"least one scan), got {max_scans!r}")
    if is_carmen(p):
        return _carmen_scans(p, laser, max_scans)
    if str(p).lower().endswith(RAWLOG_SUFFIXES):
        return read_rawlog_scans(p, label=None if laser in ("front", "rear") else laser,
                                 max_scans=max_scans)
    if is_bag(p):
        return _bag_scans(p, topic, max_scans)
    raise SequenceError(f"{p}: not a recording with laser scans slamq reads (expected a "
                        "CARMEN log .clf/.log, an MRPT .rawlog or a ROS bag)")


def _assemble(source: Path, stamps: list[float], ranges: list[np.ndarray] | np.ndarray,
              angles: np.ndarray, max_range: float, offset: tuple[float, float, float],
              fmt: str) -> Scans:
    """Scans in time order from per-scan lists (one beam layout, checked by the caller)."""
    if not stamps:
        raise SequenceError(f"{source}: no laser scans")
    t = np.asarray(stamps, np.float64)
    r = np.asarray(ranges, np.float64) if isinstance(ranges, np.ndarray) else \
        np.vstack(ranges).astype(np.float64)
    back = int(np.count_nonzero(np.diff(t) < 0))
    if back:
        order = np.argsort(t, kind="stable")
        t, r = t[order], r[order]
    return Scans(t, angles, r, max_range, offset=offset, source=str(source),
                 meta={"format": fmt, "reordered": back})


def _layout_error(source: Path, where: str, what: str) -> SequenceError:
    return SequenceError(f"{source}{where}: the scans change their {what}; slamq reads one "
                         "beam layout per recording")


def _carmen_scans(path: Path, laser: str, max_scans: int | None) -> Scans:
    scans = CarmenLog(path).scans(laser=laser, max_scans=max_scans)
    return _one_layout(path, scans, lambda s: f":{s.line}", "carmen",
                       f"{path}: no {laser} laser scans")


def _one_layout(path: Path, scans: Iterable[Any], where: Callable[[Any], str], fmt: str,
                empty: str) -> Scans:
    """Scans of one beam layout from per-scan records (a CARMEN log's, a bag's: stamp,
    ranges, angle_min, angle_increment, max_range, offset); ``where`` names a scan in an
    error, ``empty`` is the error when there is none."""
    stamps: list[float] = []
    ranges: list[np.ndarray] = []
    first = None
    max_range = 0.0
    for s in scans:
        layout = (len(s.ranges), s.angle_min, s.angle_increment, s.offset)
        if first is None:
            first = layout
        elif layout[0] != first[0]:
            raise _layout_error(path, where(s), "number of beams")
        elif not (math.isclose(layout[1], first[1], abs_tol=1e-6)
                  and math.isclose(layout[2], first[2], abs_tol=1e-9)):
            raise _layout_error(path, where(s), "beam angles")
        elif max(abs(a - b) for a, b in zip(layout[3], first[3])) > OFFSET_TOL:
            raise _layout_error(path, where(s), "laser offset on the robot")
        stamps.append(s.stamp)
        ranges.append(s.ranges)
        max_range = max(max_range, float(s.max_range))
    if first is None:
        raise SequenceError(empty)
    n, a0, step, offset = first
    angles = a0 + step * np.arange(n, dtype=np.float64)
    return _assemble(path, stamps, ranges, angles, max_range, offset, fmt)


# --------------------------------------------------------------------------------------
# MRPT rawlogs


class _Stream:
    """A rawlog's bytes (memory-mapped, or inflated from gzip) and the offset read so far."""

    def __init__(self, path: Path, data: Any) -> None:
        self.path, self.data, self.pos, self.size = path, data, 0, len(data)

    def read(self, n: int) -> bytes:
        end = self.pos + n
        if end > self.size:
            raise self.error("the file ends inside an object (truncated?)")
        out = self.data[self.pos:end]
        self.pos = end
        return out

    def skip(self, n: int) -> None:
        if self.pos + n > self.size:
            raise self.error("the file ends inside an object (truncated?)")
        self.pos += n

    def byte(self) -> int:
        if self.pos >= self.size:
            raise self.error("the file ends inside an object (truncated?)")
        self.pos += 1
        return self.data[self.pos - 1]

    def unpack(self, fmt: struct.Struct) -> tuple[Any, ...]:
        if self.pos + fmt.size > self.size:
            raise self.error("the file ends inside an object (truncated?)")
        out = fmt.unpack_from(self.data, self.pos)
        self.pos += fmt.size
        return out

    def error(self, reason: str) -> SequenceError:
        return SequenceError(f"{self.path}: byte {self.pos}: {reason}")

    def header(self) -> tuple[str, int]:
        """An object's class name (namespace dropped) and serialization version."""
        b = self.byte()
        if not b & 0x80:
            raise self.error(f"not an MRPT object (byte 0x{b:02x}; not a rawlog, or an "
                             "archive format older than MRPT 1.0)")
        name = bytes(self.read(b & 0x7F)).decode("ascii", "replace")
        if name in ("nullptr", "NULL"):
            return "nullptr", 0
        return name.rsplit("::", 1)[-1], self.byte()

    def end(self, name: str) -> None:
        if self.byte() != _END:
            raise self.error(f"{name}: no end-of-object flag where expected (an unknown "
                             "serialization version?)")


_U32, _I32, _BOOL = struct.Struct("<I"), struct.Struct("<i"), struct.Struct("<?")
_U64, _II = struct.Struct("<Q"), struct.Struct("<II")
_SCAN_HEAD = struct.Struct("<f?f")
_POSE_Q, _POSE_M, _MAT44 = struct.Struct("<7d"), struct.Struct("<12d"), struct.Struct("<16d")
#: The largest gzip rawlog inflated in memory (plain files are memory-mapped).
MAX_RAWLOG_BYTES = 1 << 33


def _rawlog_bytes(path: Path) -> Any:
    """The bytes of a rawlog: a read-only memory map, or a gzip file inflated."""
    import mmap

    st = stat_recording(path, "an MRPT rawlog")
    if st.st_size == 0:
        return b""
    try:
        with open(path, "rb") as fh:
            if fh.read(2) != b"\x1f\x8b":
                return mmap.mmap(fh.fileno(), 0, access=mmap.ACCESS_READ)
        with gzip.open(path, "rb") as gz:
            data = gz.read(MAX_RAWLOG_BYTES + 1)
    except (OSError, EOFError, gzip.BadGzipFile) as exc:
        raise SequenceError(f"{path}: cannot read "
                            f"({getattr(exc, 'strerror', None) or exc})") from None
    if len(data) > MAX_RAWLOG_BYTES:
        raise SequenceError(f"{path}: inflates to more than {MAX_RAWLOG_BYTES} bytes")
    return data


def _pose2d(s: _Stream) -> None:
    name, version = s.header()
    if name != "CPose2D":
        raise s.error(f"expected a CPose2D, found {name}")
    s.skip(12 if version == 0 else 24)
    s.end(name)


def _pose3d(s: _Stream) -> tuple[float, float, float]:
    """A ``CPose3D`` object as ``(x, y, yaw)``."""
    name, version = s.header()
    if name != "CPose3D":
        raise s.error(f"expected a CPose3D, found {name}")
    if version == 1:  # the 4 x 4 homogeneous matrix, a CMatrixD of doubles, row by row
        inner, _ = s.header()
        if inner not in ("CMatrixD", "CMatrixDouble44"):
            raise s.error(f"expected the CPose3D's CMatrixD, found {inner}")
        if s.unpack(_II) != (4, 4):
            raise s.error("a CPose3D whose matrix is not 4 x 4")
        m = s.unpack(_MAT44)
        s.end(inner)
        x, y, yaw = m[3], m[7], math.atan2(m[4], m[0])
    elif version == 2:  # x y z qr qx qy qz
        x, y, _, w, qx, qy, qz = s.unpack(_POSE_Q)
        yaw = math.atan2(2.0 * (w * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))
    elif version == 3:  # x y z, the rotation matrix row by row
        x, y, _, r00, _, _, r10, *_ = s.unpack(_POSE_M)
        yaw = math.atan2(r10, r00)
    else:
        raise s.error(f"CPose3D version {version} is not read (versions 1 to 3 are)")
    s.end(name)
    return x, y, yaw


def _matrix(s: _Stream) -> None:
    """A ``CMatrixF`` / ``CMatrix`` (a sensor-pose covariance of old scans), skipped."""
    name, _ = s.header()
    if name not in ("CMatrixF", "CMatrix"):
        raise s.error(f"expected a CMatrixF, found {name}")
    rows, cols = s.unpack(_II)
    if rows * cols > 1 << 20:
        raise s.error(f"a {rows} x {cols} sensor-pose covariance")
    s.skip(4 * rows * cols)
    s.end(name)


def _action_movement(s: _Stream, version: int) -> None:
    """A ``CActionRobotMovement2D`` of version 4-7 by odometry, skipped."""
    if version not in (4, 5, 6, 7):
        raise s.error(f"CActionRobotMovement2D version {version} is not read (4 to 7 are)")
    (method,) = s.unpack(_I32)
    if method != 0:
        raise s.error("a CActionRobotMovement2D estimated by other means than odometry "
                      "(its pose PDF) is not read")
    _pose2d(s)
    # the models: Gaussian (6 floats), Thrun (a count, 4 floats; MRPT 2.5.8 reads its two
    # additional deviations from version 7 on: its own version-6 demo rawlogs lack them)
    s.skip(4 + 24 + 4 + 16 + (8 if version >= 7 else 0))
    (vel,) = s.unpack(_BOOL)
    if version >= 7:
        if vel:
            s.skip(24)  # TTwist2D
    else:
        s.skip(16)
    (enc,) = s.unpack(_BOOL)
    if version < 7 or enc:
        s.skip(8)
    if version >= 6:
        s.skip(8)


def _odometry(s: _Stream, version: int) -> None:
    """A ``CObservationOdometry`` (versions 0-2), skipped."""
    if version > 2:
        raise s.error(f"CObservationOdometry version {version} is not read (0 to 2 are)")
    s.skip(8)  # timestamp
    _pose2d(s)
    label_len = s.unpack(_U32)[0]
    s.skip(label_len)
    if version >= 1:
        (enc,) = s.unpack(_BOOL)
        if enc:
            s.skip(8)
        (vel,) = s.unpack(_BOOL)
        if vel:
            s.skip(24 if version >= 2 else 16)


def _scan(s: _Stream, version: int) -> dict[str, Any]:
    """A ``CObservation2DRangeScan`` of version 4-8."""
    if version not in (4, 5, 6, 7, 8):
        raise s.error(f"CObservation2DRangeScan version {version} is not read (4 to 8 are)")
    aperture, right_to_left, max_range = s.unpack(_SCAN_HEAD)
    offset = _pose3d(s)
    if version < 6:
        _matrix(s)
    (n,) = s.unpack(_U32)
    if n > 1 << 20:
        raise s.error(f"a scan of {n} beams")
    ranges = s.read(4 * n)  # float32, little endian
    valid = s.read(n)  # int8 flags
    s.skip(4)  # stdError
    (ticks,) = s.unpack(_U64)
    s.skip(4)  # beamAperture
    label = ""
    if version >= 5:
        (length,) = s.unpack(_U32)
        if length > 1 << 16:
            raise s.error(f"a sensor label of {length} bytes")
        label = bytes(s.read(length)).decode("utf-8", "replace")
        s.skip(8)  # deltaPitch
    if version >= 7:
        (intensity,) = s.unpack(_BOOL)
        if intensity:
            s.skip(4 * n)
    if version >= 8:
        s.skip(4)  # sweepDuration
    return {"aperture": float(aperture), "right_to_left": bool(right_to_left),
            "max_range": float(max_range), "offset": offset, "valid": valid,
            "ranges": ranges, "beams": n, "ticks": int(ticks), "label": label}


def _observations(s: _Stream) -> Iterator[dict[str, Any]]:
    """The scans of one top-level object (a frame, an action, a lone observation)."""
    name, version = s.header()
    if name == "CActionCollection":
        (n,) = s.unpack(_U32)
        for _ in range(n):
            act, v = s.header()
            if act != "CActionRobotMovement2D":
                raise s.error(f"{act} is not read (a rawlog of 2D odometry and scans is)")
            _action_movement(s, v)
            s.end(act)
    elif name == "CSensoryFrame":
        (n,) = s.unpack(_U32)
        for _ in range(n):
            yield from _observations(s)
    elif name == "CObservation2DRangeScan":
        yield _scan(s, version)
    elif name == "CObservationOdometry":
        _odometry(s, version)
    else:
        raise s.error(f"{name} is not read (a rawlog of 2D odometry and scans is: "
                      "CActionCollection, CSensoryFrame, CObservation2DRangeScan, "
                      "CObservationOdometry)")
    s.end(name)


def read_rawlog_scans(path: PathLike, *, label: str | None = None,
                      max_scans: int | None = None) -> Scans:
    """The 2D range scans of an MRPT rawlog (see the module's notes for what is read).

    Parameters
    ----------
    path : path
        A ``.rawlog`` file, plain or gzip.
    label : str, optional
        Only the scans of this sensor label (default: the first scan's label).
    max_scans : int, optional
        Stop after this many scans.

    Returns
    -------
    Scans

    Raises
    ------
    slamq.SequenceError
        The file cannot be read, holds an object that is not read, is truncated, or its
        scans change their beam layout; the file and the byte offset are named.

    Examples
    --------
    >>> import tempfile, pathlib, numpy as np
    >>> from slamq.models import OccupancyMap
    >>> from slamq.synth import LaserSpec, Recording
    >>> from slamq.synth.writers.rawlog import write_rawlog
    >>> world = OccupancyMap(np.full((4, 4), 254, np.uint8), np.zeros((4, 4), bool), 0.1)
    >>> seq = Recording(np.array([0.0, 0.1]), np.zeros((2, 3)), np.zeros((2, 3)),
    ...                 np.array([[1, np.inf, 2]] * 2, np.float32), LaserSpec(beams=3), world)
    >>> p = write_rawlog(seq, pathlib.Path(tempfile.mkdtemp()) / "s.rawlog")
    >>> s = read_rawlog_scans(p)
    >>> s.ranges.tolist(), round(float(s.stamps[1] - s.stamps[0]), 6)
    ([[1.0, inf, 2.0], [1.0, inf, 2.0]], 0.1)
    """
    p = Path(path)
    stamps: list[float] = []
    ranges: list[np.ndarray] = []
    flags: list[bytes] = []
    first: dict[str, Any] | None = None
    max_range = 0.0
    data = _rawlog_bytes(p)
    try:
        s = _Stream(p, data)
        while s.pos < s.size and (max_scans is None or len(stamps) < max_scans):
            for obs in _observations(s):
                if first is None and (label is None or obs["label"] == label):
                    first = obs
                if first is None or obs["label"] != first["label"]:
                    continue
                if obs["beams"] != first["beams"]:
                    raise _layout_error(p, f": byte {s.pos}", "number of beams")
                if (abs(obs["aperture"] - first["aperture"]) > 1e-6
                        or obs["right_to_left"] != first["right_to_left"]):
                    raise _layout_error(p, f": byte {s.pos}", "field of view")
                if max(abs(a - b) for a, b in zip(obs["offset"], first["offset"])) > OFFSET_TOL:
                    raise _layout_error(p, f": byte {s.pos}", "laser offset on the robot")
                stamps.append((obs["ticks"] - _EPOCH_TICKS) / 1e7)
                ranges.append(obs["ranges"])
                flags.append(obs["valid"])
                max_range = max(max_range, obs["max_range"])
                if max_scans is not None and len(stamps) >= max_scans:
                    break
    finally:
        if hasattr(data, "close"):
            data.close()
    if first is None:
        what = f"with the label {label!r} " if label is not None else ""
        raise SequenceError(f"{p}: no 2D laser scans {what}in the rawlog")
    n, ap = first["beams"], first["aperture"]
    r = np.frombuffer(b"".join(ranges), "<f4").astype(np.float64).reshape(-1, n)
    ok = np.frombuffer(b"".join(flags), np.int8).reshape(-1, n) != 0
    r = np.where(ok & np.isfinite(r) & (r > 0), r, np.inf)
    i = np.arange(n, dtype=np.float64)
    step = ap / (n - 1) if n > 1 else 0.0
    angles = -ap / 2 + i * step if first["right_to_left"] else ap / 2 - i * step
    if n == 1:
        angles = np.zeros(1)
    if not max_range > 0:
        raise SequenceError(f"{p}: the scans' maximum range must be > 0, got {max_range}")
    return _assemble(p, stamps, r, angles, max_range, first["offset"], "rawlog")


# --------------------------------------------------------------------------------------
# ROS bags


def _bag_scans(path: Path, topic: str | None, max_scans: int | None) -> Scans:
    """A bag's scans through :func:`slamq.sources.bag_scans.laser_scans` (the walk
    ``slamq run``'s ``bag:`` sequences read too), in one beam layout."""
    from slamq.sources.bag_scans import choose_scan_topic, laser_scans, odometry_frame
    from slamq.sources.bagfile import open_bag

    with open_bag(path) as reader:
        topic = choose_scan_topic(reader, path, topic)
        robot = odometry_frame(reader, path)
        scans = laser_scans(reader, path, topic, robot, max_scans=max_scans, strict=False)
        return _one_layout(path, scans, lambda s: f" ({topic}, message {s.line})", "bag",
                           f"{path}: no messages on {topic}")
