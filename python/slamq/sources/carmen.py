"""CARMEN logs (``.clf`` / ``.log``, plain or gzip): the laser scans, odometry and
parameters of a real robot, read as a stream.

Record types read (the CARMEN logger's line formats)::

    PARAM name value [timestamp hostname logger_timestamp]
    ODOM x y theta tv rv accel timestamp hostname logger_timestamp
    FLASER|RLASER num_readings [range_readings] x y theta odom_x odom_y odom_theta
        timestamp hostname logger_timestamp
    RAWLASER1..4 laser_type start_angle field_of_view angular_resolution maximum_range
        accuracy remission_mode num_readings [range_readings] num_remissions [remissions]
        timestamp hostname logger_timestamp
    ROBOTLASER1|2 laser_type start_angle field_of_view angular_resolution maximum_range
        accuracy remission_mode num_readings [range_readings] num_remissions [remissions]
        laser_pose_x laser_pose_y laser_pose_theta robot_pose_x robot_pose_y
        robot_pose_theta laser_tv laser_rv forward_safety_dist side_safety_dist turn_axis
        timestamp hostname logger_timestamp

Blank lines and ``#`` comments are passed over; any other record type (``SYNC``,
``TRUEPOS``, ``NMEA``, ...) is skipped and counted (:attr:`CarmenLog.skipped`). A
malformed line of a known type is a :class:`~slamq.errors.SequenceError` naming the file
and the line number.

**Timestamps.** Every record's :attr:`stamp` is its ``timestamp`` column (the IPC
timestamp: when the sensor message was published, in Unix seconds), not the
``logger_timestamp`` (when the logger wrote it, often counted from the logger's start).
The relations files of Kümmerle et al. 2009 use the former: on the MIT CSAIL log (the
original CARMEN file), whose logger timestamps count from 0, every relation timestamp
equals an ``FLASER`` timestamp column within 5 µs; the logger column matches none. The
logger timestamp is kept as :attr:`logger_stamp`.

**Scans.** :meth:`CarmenLog.scans` turns laser records into :class:`Scan` objects: ranges
in metres with ``inf`` for no return (a reading ``>= maximum_range`` or ``<= 0``), the beam
geometry, the laser's pose on the robot and the robot's odometry pose. ``FLASER`` /
``RLASER`` lines carry no beam geometry: a field of view of 180 degrees (or the
``laser_front_laser_fov`` / ``laser_rear_laser_fov`` parameter, degrees) with the beams
spread over it end to end, the maximum range from ``robot_front_laser_max`` /
``robot_rear_laser_max`` (default 80 m, CARMEN's), the laser's offset from
``robot_frontlaser_offset``, ``..._side_offset``, ``..._angular_offset`` (the rear
laser's from ``robot_rearlaser_*``; default 0, the rear laser's angle pi). ``ROBOTLASER``
lines give the offset as ``laser pose - robot pose``.

**Odometry.** ``FLASER`` / ``RLASER`` / ``ROBOTLASER`` lines carry the robot's odometry
pose; ``RAWLASER`` lines carry none, and their pose is interpolated (SE(2), linear in time)
between the ``ODOM`` records around the scan's timestamp (the nearest one at either end).
``odometry="odom"`` takes it from the ``ODOM`` records for every scan.

**Memory.** Records are read one line at a time and handed out one by one: memory is one
line and one scan, plus the scans waiting for the next ``ODOM`` record when their odometry
must be interpolated, whatever the log's length.
"""

from __future__ import annotations

import gzip
import io
import math
import os
import stat
from collections import Counter, deque
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Union

import numpy as np

from slamq.errors import SequenceError

__all__ = ["SUFFIXES", "LASERS", "Param", "Odom", "Laser", "Scan", "CarmenLog", "is_carmen"]

#: File names read as CARMEN logs (``.gz`` too; gzip is recognised by its magic bytes).
SUFFIXES = (".clf", ".log", ".clf.gz", ".log.gz")

_LASERS = ("FLASER", "RLASER", "RAWLASER1", "RAWLASER2", "RAWLASER3", "RAWLASER4",
           "ROBOTLASER1", "ROBOTLASER2")
#: The lasers of each position (``front``: FLASER, RAWLASER1, ROBOTLASER1; ``rear``:
#: RLASER, RAWLASER2, ROBOTLASER2).
LASERS = {"front": ("FLASER", "RAWLASER1", "ROBOTLASER1"),
          "rear": ("RLASER", "RAWLASER2", "ROBOTLASER2")}
_DEFAULT_MAX_RANGE = 80.0
#: The longest line read (characters): a 1081-beam scan with remissions is about 20,000.
MAX_LINE = 1 << 20


@dataclass(frozen=True)
class Param:
    """A ``PARAM`` record: a robot or sensor setting (``value`` as written)."""

    name: str
    value: str
    stamp: float
    line: int


@dataclass(frozen=True)
class Odom:
    """An ``ODOM`` record: the odometry pose (m, m, rad) and velocities at ``stamp``."""

    x: float
    y: float
    theta: float
    tv: float
    rv: float
    accel: float
    stamp: float
    logger_stamp: float
    host: str
    line: int


@dataclass(frozen=True, eq=False)
class Laser:
    """A laser record (``FLASER``, ``RLASER``, ``RAWLASER1..4``, ``ROBOTLASER1|2``).

    ``ranges`` are the readings as logged (float32, metres). ``start_angle``, ``fov``,
    ``angular_resolution``, ``max_range`` and ``accuracy`` are NaN for ``FLASER`` /
    ``RLASER`` lines, which do not carry them. ``laser_pose`` / ``robot_pose`` are the
    odometry poses ``(x, y, theta)`` the line carries (None for ``RAWLASER``).
    """

    kind: str
    ranges: np.ndarray
    start_angle: float
    fov: float
    angular_resolution: float
    max_range: float
    accuracy: float
    laser_pose: tuple[float, float, float] | None
    robot_pose: tuple[float, float, float] | None
    stamp: float
    logger_stamp: float
    host: str
    line: int


Record = Union[Param, Odom, Laser]


@dataclass(frozen=True, eq=False)
class Scan:
    """One laser scan ready for a SLAM program.

    Attributes
    ----------
    stamp : float
        Unix seconds (the record's ``timestamp`` column).
    odom : tuple of float
        The robot's odometry pose ``(x, y, yaw)`` at ``stamp``.
    ranges : numpy.ndarray
        ``(beams,)`` float32 metres; ``inf`` = no return.
    angle_min, angle_increment : float
        The first beam's angle in the laser frame and the step between beams, radians
        (counter-clockwise).
    max_range : float
    range_noise : float
        The laser's accuracy (standard deviation, metres).
    offset : tuple of float
        ``(x, y, yaw)`` of the laser on the robot.
    kind : str
        The record type.
    line : int
        The line of the log it came from.
    """

    stamp: float
    odom: tuple[float, float, float]
    ranges: np.ndarray
    angle_min: float
    angle_increment: float
    max_range: float
    range_noise: float
    offset: tuple[float, float, float]
    kind: str
    line: int


def is_carmen(path: str | os.PathLike[str]) -> bool:
    """Whether a file name is a CARMEN log's (:data:`SUFFIXES`, any case).

    Examples
    --------
    >>> is_carmen("intel.clf"), is_carmen("run.LOG.gz"), is_carmen("a.rawlog")
    (True, True, False)
    """
    return str(path).lower().endswith(SUFFIXES)


def stat_recording(path: Path, what: str) -> os.stat_result:
    """``os.stat`` of a recording (a log, a rawlog) that must be a regular file, or a
    SequenceError naming it and why (missing, a directory, a FIFO or device)."""
    try:
        st = os.stat(path)
    except OSError as exc:
        raise SequenceError(f"{path}: cannot read ({exc.strerror or exc})") from None
    if stat.S_ISDIR(st.st_mode):
        raise SequenceError(f"{path}: is a directory, not {what}")
    if not stat.S_ISREG(st.st_mode):
        raise SequenceError(f"{path}: not a regular file (a FIFO, device or socket)")
    return st


def _open(path: Path) -> IO[str]:
    stat_recording(path, "a CARMEN log")
    try:
        with open(path, "rb") as head:
            gz = head.read(2) == b"\x1f\x8b"
        binary: IO[bytes] = gzip.open(path, "rb") if gz else open(path, "rb")
        return io.TextIOWrapper(binary, encoding="utf-8", errors="replace", newline=None)
    except OSError as exc:
        raise SequenceError(f"{path}: cannot read ({exc.strerror or exc})") from None


def _pose(f: list[str], i: int) -> tuple[float, float, float]:
    pose = float(f[i]), float(f[i + 1]), float(f[i + 2])
    if not all(map(math.isfinite, pose)):
        raise ValueError(f"a pose is not finite ({' '.join(f[i:i + 3])})")
    return pose


def _stamp(text: str) -> float:
    t = float(text)
    if not math.isfinite(t):
        raise ValueError(f"the timestamp is not finite ({text})")
    return t


def _count(f: list[str], i: int, what: str) -> int:
    if i >= len(f):
        raise ValueError(f"ends before {what}")
    n = int(f[i])
    if n < 0:
        raise ValueError(f"{what} is negative ({n})")
    return n


def _need(f: list[str], n: int) -> None:
    if len(f) != n:
        raise ValueError(f"{len(f)} fields, expected {n}")


def _parse(f: list[str], no: int) -> Record:
    """One record from the fields of a line of a known type (ValueError / IndexError on a
    malformed one)."""
    kind = f[0]
    if kind == "PARAM":
        if len(f) < 3:
            raise ValueError("a PARAM line needs a name and a value")
        return Param(f[1], f[2], float(f[3]) if len(f) > 3 else math.nan, no)
    if kind == "ODOM":
        _need(f, 10)
        return Odom(*_pose(f, 1), *map(float, f[4:7]), _stamp(f[7]), float(f[9]), f[8], no)
    if kind in ("FLASER", "RLASER"):
        n = _count(f, 1, "num_readings")
        _need(f, n + 11)
        j = 2 + n
        nan = math.nan
        return Laser(kind, np.array(f[2:j], np.float32), nan, nan, nan, nan, nan,
                     _pose(f, j), _pose(f, j + 3), _stamp(f[j + 6]), float(f[j + 8]),
                     f[j + 7], no)
    # RAWLASERn / ROBOTLASERn
    head = [float(x) for x in f[2:8]]  # laser_type .. remission_mode: 7 fields after kind
    if len(head) != 6:
        raise ValueError("ends before num_readings")
    n = _count(f, 8, "num_readings")
    j = 9 + n
    m = _count(f, j, "num_remissions")
    j += 1 + m
    robot = kind.startswith("ROBOT")
    _need(f, j + (11 if robot else 0) + 3)
    ranges = np.array(f[9:9 + n], np.float32)
    start, fov, res, max_range, accuracy = head[0], head[1], head[2], head[3], head[4]
    if robot:
        lpose, rpose = _pose(f, j), _pose(f, j + 3)
        j += 11
    else:
        lpose = rpose = None
    return Laser(kind, ranges, start, fov, res, max_range, accuracy, lpose, rpose,
                 _stamp(f[j]), float(f[j + 2]), f[j + 1], no)


class CarmenLog:
    """A CARMEN log, read as a stream of records or scans (each pass reads the file again).

    Parameters
    ----------
    path : path
        A ``.clf`` / ``.log`` file, plain or gzip.

    Attributes
    ----------
    path : pathlib.Path
    counts : collections.Counter
        Records read by the last finished pass, per type.
    skipped : collections.Counter
        Lines of unknown record types skipped by the last pass, per type.

    Raises
    ------
    slamq.SequenceError
        The file is missing or not a regular file (at construction); a malformed line
        (while reading: the file and the line number are named).

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "a.clf"
    >>> _ = p.write_text("PARAM robot_front_laser_max 4.0 0 h 0\\n"
    ...                  "ODOM 1 2 0 0 0 0 10.5 h 0.1\\n"
    ...                  "SYNC 10.6 h 0.2\\n"
    ...                  "FLASER 3 1.0 4.0 2.5 1 2 0 1 2 0 10.75 h 0.25\\n")
    >>> log = CarmenLog(p)
    >>> [type(r).__name__ for r in log.records()]
    ['Param', 'Odom', 'Laser']
    >>> dict(log.skipped)
    {'SYNC': 1}
    >>> scan = next(log.scans())
    >>> scan.stamp, scan.odom, scan.ranges.tolist(), round(scan.angle_increment, 4)
    (10.75, (1.0, 2.0, 0.0), [1.0, inf, 2.5], 1.5708)
    """

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = Path(path)
        _open(self.path).close()
        self.counts: Counter[str] = Counter()
        self.skipped: Counter[str] = Counter()

    def __repr__(self) -> str:
        return f"CarmenLog({str(self.path)!r})"

    def records(self) -> Iterator[Record]:
        """The records in file order, one at a time (:class:`Param`, :class:`Odom`,
        :class:`Laser`); unknown types are skipped and counted in :attr:`skipped`."""
        counts: Counter[str] = Counter()
        skipped: Counter[str] = Counter()
        with _open(self.path) as text:
            no = 0
            while True:
                try:
                    line = text.readline(MAX_LINE)
                except (OSError, EOFError, gzip.BadGzipFile) as exc:
                    raise SequenceError(f"{self.path}:{no + 1}: cannot read "
                                        f"({getattr(exc, 'strerror', None) or exc})") from None
                if not line:
                    break
                no += 1
                if len(line) == MAX_LINE and not line.endswith("\n"):
                    raise SequenceError(f"{self.path}:{no}: a line longer than {MAX_LINE} "
                                        f"characters (not a CARMEN log?)")
                f = line.split()
                if not f or f[0].startswith("#"):
                    continue
                kind = f[0]
                if kind != "PARAM" and kind != "ODOM" and kind not in _LASERS:
                    skipped[kind[:40]] += 1
                    continue
                try:
                    rec = _parse(f, no)
                except (IndexError, ValueError) as exc:
                    raise SequenceError(f"{self.path}:{no}: malformed {kind} line "
                                        f"({exc})") from None
                counts[kind] += 1
                yield rec
        self.counts, self.skipped = counts, skipped

    def scans(self, *, laser: str = "front", odometry: str = "auto",
              max_scans: int | None = None) -> Iterator[Scan]:
        """The scans of one laser in file order, with the robot's odometry pose.

        Parameters
        ----------
        laser : {"front", "rear"}, default "front"
            Which laser's records (:data:`LASERS`).
        odometry : {"auto", "odom"}, default "auto"
            ``auto``: the odometry pose the laser line carries, interpolated between the
            ``ODOM`` records for lines that carry none (``RAWLASER``); ``odom``: from the
            ``ODOM`` records for every scan.
        max_scans : int, optional
            Stop after this many scans (a cut of the log's head).

        Raises
        ------
        slamq.SequenceError
            A malformed line; a scan needs ``ODOM`` records and the log has none.

        Examples
        --------
        >>> import tempfile, pathlib
        >>> p = pathlib.Path(tempfile.mkdtemp()) / "raw.log"
        >>> _ = p.write_text("ODOM 0 0 0 0 0 0 1.0 h 1.0\\n"
        ...                  "RAWLASER1 0 -1.5708 3.1416 1.5708 8 0.01 0 3 1 2 3 0 1.5 h 1.5\\n"
        ...                  "ODOM 1 0 0 0 0 0 2.0 h 2.0\\n")
        >>> [s.odom for s in CarmenLog(p).scans()]
        [(0.5, 0.0, 0.0)]
        """
        if laser not in LASERS:
            raise SequenceError(f"{self.path}: laser must be one of {', '.join(LASERS)}, "
                                f"got {laser!r}")
        if odometry not in ("auto", "odom"):
            raise SequenceError(f"{self.path}: odometry must be 'auto' or 'odom', "
                                f"got {odometry!r}")
        if max_scans is not None and max_scans < 0:
            raise SequenceError(f"{self.path}: max_scans must be >= 0, got {max_scans}")
        kinds = LASERS[laser]
        params: dict[str, str] = {}
        pending: deque[Laser] = deque()  # scans waiting for the ODOM record after them
        prev: Odom | None = None
        done = 0
        if max_scans == 0:
            return
        records = self.records()
        try:
            for rec in records:
                if isinstance(rec, Param):
                    params[rec.name.lower()] = rec.value
                    continue
                if isinstance(rec, Odom):
                    while pending:
                        head = pending[0]
                        if odometry == "auto" and head.robot_pose is not None:
                            pose = head.robot_pose
                        elif head.stamp <= rec.stamp:
                            pose = _interpolate(prev, rec, head.stamp)
                        else:
                            break
                        yield self._scan(pending.popleft(), params, pose)
                        done += 1
                        if max_scans is not None and done >= max_scans:
                            return
                    prev = rec
                    continue
                if rec.kind not in kinds:
                    continue
                if odometry == "auto" and rec.robot_pose is not None and not pending:
                    yield self._scan(rec, params, rec.robot_pose)
                    done += 1
                    if max_scans is not None and done >= max_scans:
                        return
                else:
                    pending.append(rec)
            while pending:  # after the last ODOM record: its pose
                head = pending.popleft()
                if odometry == "auto" and head.robot_pose is not None:
                    pose = head.robot_pose
                elif prev is None:
                    raise SequenceError(f"{self.path}:{head.line}: a {head.kind} scan needs "
                                        f"odometry from ODOM records and the log has none")
                else:
                    pose = _interpolate(prev, None, head.stamp)
                yield self._scan(head, params, pose)
                done += 1
                if max_scans is not None and done >= max_scans:
                    return
        finally:
            records.close()

    def _scan(self, rec: Laser, params: dict[str, str],
              odom: tuple[float, float, float]) -> Scan:
        """A laser record as a :class:`Scan` (the beam geometry and the laser's offset from
        the record or the parameters read so far)."""
        pos = "front" if rec.kind in LASERS["front"] else "rear"
        n = len(rec.ranges)

        def param(name: str, default: float) -> float:
            value = params.get(name)
            if value is None:
                return default
            try:
                return float(value)
            except ValueError:
                raise SequenceError(f"{self.path}: PARAM {name} is not a number "
                                    f"({value!r})") from None

        if rec.kind in ("FLASER", "RLASER"):
            fov = math.radians(param(f"laser_{pos}_laser_fov", 180.0))
            angle_min = -fov / 2
            step = fov / (n - 1) if n > 1 else 0.0
            max_range = param(f"robot_{pos}_laser_max", _DEFAULT_MAX_RANGE)
            noise = 0.01
        else:
            step = rec.angular_resolution
            if not math.isfinite(step) or step <= 0:
                step = rec.fov / (n - 1) if n > 1 else 0.0
            angle_min, max_range = rec.start_angle, rec.max_range
            noise = rec.accuracy if math.isfinite(rec.accuracy) and rec.accuracy > 0 else 0.01
        if rec.laser_pose is not None and rec.robot_pose is not None and \
                rec.kind.startswith("ROBOTLASER"):
            offset = _relative(rec.robot_pose, rec.laser_pose)
        else:
            offset = (param(f"robot_{pos}laser_offset", 0.0),
                      param(f"robot_{pos}laser_side_offset", 0.0),
                      param(f"robot_{pos}laser_angular_offset",
                            0.0 if pos == "front" else math.pi))
        if not (math.isfinite(max_range) and max_range > 0):
            raise SequenceError(f"{self.path}:{rec.line}: {rec.kind} maximum range must be "
                                f"> 0, got {max_range}")
        r = rec.ranges
        ranges = np.where(np.isfinite(r) & (r > 0) & (r < max_range), r,
                          np.float32(np.inf)).astype(np.float32)
        return Scan(rec.stamp, odom, ranges, angle_min, step, max_range, noise, offset,
                    rec.kind, rec.line)


def _relative(a: tuple[float, float, float],
              b: tuple[float, float, float]) -> tuple[float, float, float]:
    """Pose ``b`` in the frame of pose ``a`` (``a^-1 * b``)."""
    c, s = math.cos(a[2]), math.sin(a[2])
    dx, dy = b[0] - a[0], b[1] - a[1]
    dth = b[2] - a[2]
    return c * dx + s * dy, -s * dx + c * dy, math.atan2(math.sin(dth), math.cos(dth))


def _interpolate(a: Odom | None, b: Odom | None, t: float) -> tuple[float, float, float]:
    """The odometry pose at ``t`` between ``ODOM`` records ``a`` and ``b`` (SE(2): positions
    linear in time, the angle along the shorter way); the nearest record outside them."""
    if a is None and b is None:
        raise ValueError("no ODOM record")
    if a is None or (b is not None and t >= b.stamp):
        assert b is not None
        return b.x, b.y, b.theta
    if b is None or t <= a.stamp or b.stamp <= a.stamp:
        return a.x, a.y, a.theta
    w = (t - a.stamp) / (b.stamp - a.stamp)
    dth = math.atan2(math.sin(b.theta - a.theta), math.cos(b.theta - a.theta))
    th = a.theta + w * dth
    return (a.x + w * (b.x - a.x), a.y + w * (b.y - a.y), math.atan2(math.sin(th), math.cos(th)))

