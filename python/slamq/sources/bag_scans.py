"""Laser scans from ROS bags (``sensor_msgs/LaserScan``), each with the robot's odometry
pose at its stamp, as :class:`slamq.sources.carmen.Scan`: the stream that
:func:`slamq.synth.writers.carmen_rawlog.write_scans_rawlog` writes as an MRPT rawlog
(``slamq run``'s ``bag:`` sequences).

**Scans** are taken in the bag's order (as a CARMEN log's in file order); each keeps its
header stamp (the bag time when the stamp is zero), its beam geometry (``angle_min``,
``angle_increment``, ``range_max``) and its ranges, a reading not strictly between
``range_min`` and ``range_max`` (docs/spec.md 7b) or not finite written as no return
(``inf``). :func:`slamq.load_scans` reads bags through the same walk
(:func:`laser_scans`).

**Odometry.** The odometry topic (``nav_msgs/Odometry`` or another pose type that
:func:`slamq.sources.bag_poses.read_bag_trajectory` reads) is read whole first and sorted
by stamp (a log whose stamps run backwards, such as Intel's, is put in time order); each
scan's pose is interpolated at its stamp (positions linear in time, the heading along the
shorter arc; the nearest pose before the first and after the last).

**Laser offset.** The pose of the scan's frame in the odometry's child frame
(``base_link``), from the first ``/tf_static`` (else ``/tf``) transform between the two,
in either direction; none is needed when the frames are the same. Planar: the offset's x,
y and yaw. (:func:`slamq.load_scans`, which has no odometry topic, takes the robot's frame
from the bag's only ``nav_msgs/Odometry`` topic; without it, or without a transform to
it, from the first transform whose child is the scans' frame, else a zero offset.)
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any, NamedTuple

import numpy as np

from slamq.errors import BagError
from slamq.sources.bagfile import (
    POSE_TYPES,
    TF_TYPE,
    bag_connections,
    bag_deserialize,
    bag_messages,
    describe_topics,
    header_stamp,
    open_bag,
    quat_yaw,
    topic_types,
)
from slamq.sources.carmen import Scan
from slamq.sources.files import PathLike

__all__ = ["SCAN_TYPE", "read_bag_scans"]

SCAN_TYPE = "sensor_msgs/msg/LaserScan"
ODOMETRY_TYPE = "nav_msgs/msg/Odometry"
#: The range noise written with each scan (a LaserScan carries none), metres: CARMEN's.
RANGE_NOISE = 0.01


def _frame(name: str) -> str:
    return str(name).lstrip("/")


def _odometry(reader: Any, bag: PathLike, topic: str
              ) -> tuple[np.ndarray, np.ndarray, str | None]:
    """The odometry poses ``(N,)`` stamps and ``(N, 3)`` x, y, yaw sorted by stamp (stable),
    and the odometry's child frame (None when the messages do not name one)."""
    from slamq.sources.bag_poses import _pose_of

    conns = bag_connections(reader, bag, topic, POSE_TYPES)
    rows: list[tuple[float, float, float, float]] = []
    child: str | None = None
    for conn, ns, raw in bag_messages(reader, bag, conns):
        msg = bag_deserialize(reader, bag, conn, raw)
        if conn.msgtype == "nav_msgs/msg/Path":
            raise BagError(f"{bag}: {topic} is a nav_msgs/Path; the odometry of a bag: "
                           "sequence must be a stream of poses (nav_msgs/Odometry)")
        p, q = _pose_of(conn.msgtype, msg)
        if child is None and getattr(msg, "child_frame_id", ""):
            child = _frame(msg.child_frame_id)
        rows.append((header_stamp(msg.header, ns), float(p.x), float(p.y), quat_yaw(q)))
    if not rows:
        raise BagError(f"{bag}: no odometry on {topic}")
    a = np.asarray(rows, np.float64)
    if not np.isfinite(a).all():
        row = int(np.flatnonzero(~np.isfinite(a).all(axis=1))[0])
        raise BagError(f"{bag}: {topic}: message {row + 1} holds a NaN or infinite pose")
    a = a[np.argsort(a[:, 0], kind="stable")]
    return a[:, 0], a[:, 1:], child


def _pose_at(t: np.ndarray, pose: np.ndarray, stamp: float) -> tuple[float, float, float]:
    """The odometry pose at ``stamp`` (linear in time; the heading on the shorter arc)."""
    hi = int(np.searchsorted(t, stamp, side="left"))
    if hi == 0:
        return tuple(float(v) for v in pose[0])  # type: ignore[return-value]
    if hi >= t.shape[0]:
        return tuple(float(v) for v in pose[-1])  # type: ignore[return-value]
    if t[hi] == stamp:
        return tuple(float(v) for v in pose[hi])  # type: ignore[return-value]
    t0, t1 = float(t[hi - 1]), float(t[hi])
    a, b = pose[hi - 1], pose[hi]
    w = (stamp - t0) / (t1 - t0) if t1 > t0 else 0.0
    dth = math.atan2(math.sin(b[2] - a[2]), math.cos(b[2] - a[2]))
    th = float(a[2]) + w * dth
    return (float(a[0] + w * (b[0] - a[0])), float(a[1] + w * (b[1] - a[1])),
            math.atan2(math.sin(th), math.cos(th)))


def _transforms(reader: Any, bag: PathLike) -> Iterator[tuple[str, str, Any]]:
    """``(parent, child, transform)`` of every transform on ``/tf_static``, then ``/tf``
    (a ROS 1 bag repeats its static transforms on ``/tf``), frames without a leading /."""
    types = topic_types(reader)
    for topic in ("/tf_static", "/tf"):
        if types.get(topic) != TF_TYPE:
            continue
        for conn, _ns, raw in bag_messages(reader, bag, bag_connections(
                reader, bag, topic, (TF_TYPE,))):
            for tf in bag_deserialize(reader, bag, conn, raw).transforms:
                yield _frame(tf.header.frame_id), _frame(tf.child_frame_id), tf.transform


def laser_offset(reader: Any, bag: PathLike, robot: str | None, laser: str
                 ) -> tuple[float, float, float] | None:
    """``(x, y, yaw)`` of frame ``laser`` in frame ``robot`` from the first transform
    between the two on ``/tf_static``, else ``/tf``, in either direction (inverted when
    ``laser`` is its parent); with ``robot`` None (not known), from the first transform
    whose child is ``laser`` (its parent taken as the robot). None when there is none."""
    for parent, child, tr in _transforms(reader, bag):
        if robot is None:
            if child != laser:
                continue
        elif {parent, child} != {robot, laser}:
            continue
        x, y, yaw = float(tr.translation.x), float(tr.translation.y), quat_yaw(tr.rotation)
        if robot is None or parent == robot:
            return x, y, yaw
        c, s = math.cos(yaw), math.sin(yaw)  # the inverse transform
        return -(c * x + s * y), s * x - c * y, -yaw
    return None


def choose_scan_topic(reader: Any, bag: PathLike, topic: str | None) -> str:
    """``topic``, or when None the bag's only ``LaserScan`` topic, else ``/scan``."""
    if topic is not None:
        return topic
    types = topic_types(reader)
    found = sorted(t for t, m in types.items() if m == SCAN_TYPE)
    if len(found) != 1 and "/scan" not in found:
        raise BagError(f"{bag}: {'no' if not found else 'more than one'} "
                       f"{SCAN_TYPE} topic (name one); {describe_topics(types)}")
    return found[0] if len(found) == 1 else "/scan"


def odometry_frame(reader: Any, bag: PathLike) -> str | None:
    """The child frame (the robot's) of the bag's only ``nav_msgs/Odometry`` topic, from
    its first message; None without one such topic or frame."""
    topics = [t for t, m in topic_types(reader).items() if m == ODOMETRY_TYPE]
    if len(topics) != 1:
        return None
    conns = bag_connections(reader, bag, topics[0], (ODOMETRY_TYPE,))
    for conn, _ns, raw in bag_messages(reader, bag, conns):
        return _frame(bag_deserialize(reader, bag, conn, raw).child_frame_id) or None
    return None


class BagScan(NamedTuple):
    """One ``LaserScan`` message as read: the fields of :class:`~slamq.sources.carmen.Scan`
    but the odometry."""

    stamp: float
    ranges: np.ndarray
    angle_min: float
    angle_increment: float
    max_range: float
    offset: tuple[float, float, float]
    line: int


def laser_scans(reader: Any, bag: PathLike, topic: str, robot: str | None, *,
                max_scans: int | None = None, strict: bool = True) -> Iterator[BagScan]:
    """The ``LaserScan`` messages of ``topic`` in bag order (see the module's notes).

    ``robot`` is the robot's frame (the odometry's child frame) the laser offset is taken
    in, None when not known. ``strict`` (:func:`read_bag_scans`): a scan frame other than
    the robot's needs a transform between the two (:func:`laser_offset`), else
    :class:`~slamq.BagError`; with ``robot`` None the offset is zero. Not ``strict``
    (:func:`slamq.load_scans`): without such a transform, the first transform whose child
    is the scan's frame (its parent taken as the robot), else zero. Each frame's offset is
    looked up once.
    """
    conns = bag_connections(reader, bag, topic, (SCAN_TYPE,))
    if max_scans == 0:
        return
    offsets: dict[str, tuple[float, float, float]] = {}
    done = 0
    for conn, ns, raw in bag_messages(reader, bag, conns):
        msg = bag_deserialize(reader, bag, conn, raw)
        frame = _frame(msg.header.frame_id)
        if frame not in offsets:
            found = (0.0, 0.0, 0.0) if frame in ("", robot) or (strict and robot is None) \
                else laser_offset(reader, bag, robot, frame)
            if found is None and strict:
                raise BagError(f"{bag}: no /tf_static or /tf transform between the "
                               f"odometry's frame {robot} and the scan's frame {frame} "
                               f"({topic})")
            if found is None and robot is not None:
                found = laser_offset(reader, bag, None, frame)
            offsets[frame] = found or (0.0, 0.0, 0.0)
        r = np.asarray(msg.ranges, np.float32)
        if r.size == 0:
            raise BagError(f"{bag}: {topic}: scan {done + 1} has no beams")
        lo, hi = float(msg.range_min), float(msg.range_max)
        if not (math.isfinite(hi) and hi > 0):
            raise BagError(f"{bag}: {topic}: scan {done + 1} has range_max {hi}")
        # valid: range_min < r < range_max (docs/spec.md 7b); else no return
        ranges = np.where(np.isfinite(r) & (r > lo) & (r < hi), r,
                          np.float32(np.inf)).astype(np.float32)
        yield BagScan(header_stamp(msg.header, ns), ranges, float(msg.angle_min),
                        float(msg.angle_increment), hi, offsets[frame], done + 1)
        done += 1
        if max_scans is not None and done >= max_scans:
            return


def read_bag_scans(bag: PathLike, scan_topic: str | None = "/scan", odom_topic: str = "/odom",
                   *, max_scans: int | None = None) -> Iterator[Scan]:
    """The laser scans of a bag in bag order, each with the odometry pose at its stamp.

    Parameters
    ----------
    bag : path
        A ROS 1 ``.bag``, a ROS 2 ``.db3`` / ``.mcap`` file or ROS 2 bag folder.
    scan_topic : str or None, default "/scan"
        A ``sensor_msgs/LaserScan`` topic; None: the bag's only one, else ``/scan``.
    odom_topic : str, default "/odom"
        ``nav_msgs/Odometry`` (or ``PoseStamped``, ``PoseWithCovarianceStamped``,
        ``TransformStamped``): the robot's odometry.
    max_scans : int, optional
        Stop after this many scans (a cut of the bag's head).

    Yields
    ------
    Scan
        ``kind`` ``"LaserScan"``, ``line`` the scan's 1-based index in the bag.

    Raises
    ------
    slamq.BagError
        A missing or unreadable bag, a missing topic or one of another type (the message
        lists the bag's topics), no odometry, a scan frame with no transform to the
        odometry's child frame, a scan with no beams or a ``range_max`` that is not finite
        and positive.

    Examples
    --------
    >>> scans = read_bag_scans("intel.orig.bag", max_scans=300)  # doctest: +SKIP
    >>> next(read_bag_scans("missing.bag"))
    Traceback (most recent call last):
    ...
    slamq.errors.BagError: missing.bag: no such file or folder
    """
    if max_scans is not None and max_scans < 0:
        raise BagError(f"{bag}: max_scans must be >= 0, got {max_scans}")
    with open_bag(bag) as reader:
        topic = choose_scan_topic(reader, bag, scan_topic)
        bag_connections(reader, bag, topic, (SCAN_TYPE,))  # the scans' topic first
        odom_t, odom, base = _odometry(reader, bag, odom_topic)
        for s in laser_scans(reader, bag, topic, base, max_scans=max_scans):
            yield Scan(s.stamp, _pose_at(odom_t, odom, s.stamp), s.ranges, s.angle_min,
                       s.angle_increment, s.max_range, RANGE_NOISE, s.offset, "LaserScan",
                       s.line)
