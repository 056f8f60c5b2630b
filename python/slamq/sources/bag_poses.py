"""Poses from ROS bags: PoseStamped, PoseWithCovarianceStamped, Odometry, TransformStamped,
nav_msgs/Path (its last message) or ``/tf`` chains, as a :class:`~slamq.models.Trajectory`."""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from slamq.errors import BagError
from slamq.models import Trajectory
from slamq.models.trajectory import quat_multiply, quat_rotate
from slamq.sources.bagfile import (
    PATH_TYPE,
    POSE_TYPES,
    TF_TYPE,
    bag_connections,
    bag_deserialize,
    bag_messages,
    describe_topics,
    header_stamp,
    open_bag,
    topic_types,
)
from slamq.sources.files import PathLike

__all__ = ["read_bag_trajectory"]


def _slerp(q0: np.ndarray, q1: np.ndarray, s: np.ndarray) -> np.ndarray:
    dot = np.sum(q0 * q1, axis=-1)
    q1 = np.where((dot < 0)[:, None], -q1, q1)
    dot = np.abs(dot)
    out = np.empty_like(q0)
    lin = dot > 0.9995
    # nearly parallel: normalised lerp
    if np.any(lin):
        m = q0[lin] + s[lin, None] * (q1[lin] - q0[lin])
        out[lin] = m / np.linalg.norm(m, axis=-1, keepdims=True)
    if np.any(~lin):
        theta = np.arccos(np.clip(dot[~lin], -1.0, 1.0))
        sin = np.sin(theta)
        a = np.sin((1.0 - s[~lin]) * theta) / sin
        b = np.sin(s[~lin] * theta) / sin
        out[~lin] = a[:, None] * q0[~lin] + b[:, None] * q1[~lin]
    return out


@dataclasses.dataclass
class _Series:
    """Timestamped rigid transforms of one tf edge (or one pose topic)."""

    t: list[float] = dataclasses.field(default_factory=list)
    p: list[tuple[float, float, float]] = dataclasses.field(default_factory=list)
    q: list[tuple[float, float, float, float]] = dataclasses.field(default_factory=list)
    static: bool = False

    def add(self, t: float, p: Any, q: Any) -> None:
        self.t.append(t)
        self.p.append((float(p.x), float(p.y), float(p.z)))
        self.q.append((float(q.w), float(q.x), float(q.y), float(q.z)))

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        t = np.asarray(self.t, dtype=np.float64)
        p = np.asarray(self.p, dtype=np.float64).reshape(-1, 3)
        q = np.asarray(self.q, dtype=np.float64).reshape(-1, 4)
        order = np.argsort(t, kind="stable")
        return t[order], p[order], q[order]

    def at(self, times: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Transforms at ``times`` (linear / slerp); ``ok`` False outside the data range."""
        t, p, q = self.arrays()
        n = len(times)
        if self.static or len(t) == 1:
            ok = np.ones(n, bool) if self.static else np.isclose(times, t[0], atol=1e-9)
            return np.repeat(p[-1:], n, 0), np.repeat(q[-1:], n, 0), ok
        ok = (times >= t[0]) & (times <= t[-1])
        i = np.clip(np.searchsorted(t, times, side="right") - 1, 0, len(t) - 2)
        dt = t[i + 1] - t[i]
        s = np.where(dt > 0, (times - t[i]) / np.where(dt > 0, dt, 1.0), 0.0)
        s = np.clip(s, 0.0, 1.0)
        pos = p[i] + s[:, None] * (p[i + 1] - p[i])
        rot = _slerp(q[i], q[i + 1], s)
        return pos, rot, ok


def _strip(frame: str) -> str:
    return frame.lstrip("/")


def read_bag_trajectory(
    bag: PathLike,
    topic: str | None = None,
    *,
    parent_frame: str | None = None,
    child_frame: str | None = None,
) -> Trajectory:
    """Read a trajectory (timestamps, positions, wxyz orientations) from a bag.

    Parameters
    ----------
    bag : path
        ROS1 ``.bag``, ROS2 ``.db3`` / ``.mcap`` file, or ROS2 bag folder.
    topic : str, optional
        A ``geometry_msgs/PoseStamped``, ``PoseWithCovarianceStamped``,
        ``TransformStamped``, ``PointStamped`` (identity orientations), ``nav_msgs/Odometry``
        or ``nav_msgs/Path`` topic (for a Path, the poses of its last message), or a
        ``tf2_msgs/TFMessage`` topic (``/tf``; ``"/tf:map->base_link"`` or evo's
        ``"/tf:map.base_link"`` also names the frames). By default the bag's only pose
        topic, else ``/tf``. The poses equal evo's ``read_bag_trajectory`` for the topic
        types both read; ``/tf`` needs no ROS install here.
    parent_frame, child_frame : str, optional
        For ``/tf``: the pose of ``child_frame`` in ``parent_frame``. A chain of frames
        (``map -> odom -> base_link``) is composed through ``/tf`` and ``/tf_static``, at the
        stamps of the chain's busiest edge, interpolating the other edges (samples outside
        an edge's time range are dropped). Without frames, ``/tf`` must hold one pair only.

    Returns
    -------
    slamq.Trajectory
        Stamps are the header stamps (the bag time when a stamp is zero), in seconds.

    Raises
    ------
    BagError
        Missing/truncated bag, missing topic (the message lists the topics), wrong type,
        unknown frames (the message lists the frame pairs), no poses.
    TrajectoryError
        A NaN or infinite pose or an all-zero quaternion (other quaternions are
        normalised), naming the bag, the topic and the pose.

    Examples
    --------
    >>> traj = read_bag_trajectory("run1.bag", "/odom")  # doctest: +SKIP
    >>> traj = read_bag_trajectory("run1.bag", "/tf", parent_frame="map",
    ...                            child_frame="base_link")  # doctest: +SKIP
    """

    if topic is not None and ":" in topic:  # "/tf:map->base_link", or evo's "/tf:map.base_link"
        topic, _, frames = topic.partition(":")
        parent, _, child = frames.partition("->" if "->" in frames else ".")
        parent_frame = parent_frame or parent.strip() or None
        child_frame = child_frame or child.strip() or None
    with open_bag(bag) as reader:
        types = topic_types(reader)
        if topic is None:
            candidates = sorted(t for t, m in types.items() if m in POSE_TYPES)
            if len(candidates) == 1:
                topic = candidates[0]
            elif not candidates and "/tf" in types:
                topic = "/tf"
            elif not candidates:
                raise BagError(f"{bag}: no pose topic; {describe_topics(types)}")
            else:
                raise BagError(
                    f"{bag}: several pose topics ({', '.join(candidates)}); name one with topic="
                )
        if topic not in types:
            raise BagError(f"{bag}: no topic {topic}; {describe_topics(types)}")
        msgtype = types[topic]
        if msgtype == TF_TYPE:
            t, p, q = _tf_trajectory(reader, bag, topic, parent_frame, child_frame)
            where = f"{bag}:{topic}:{parent_frame or ''}->{child_frame or ''}"
        else:
            conns = bag_connections(reader, bag, topic, POSE_TYPES)
            series = _Series()
            for conn, ns, raw in bag_messages(reader, bag, conns):
                msg = bag_deserialize(reader, bag, conn, raw)
                if conn.msgtype == PATH_TYPE:
                    series = _Series()
                    for ps in msg.poses:
                        series.add(header_stamp(ps.header, ns), ps.pose.position,
                                   ps.pose.orientation)
                    continue
                pose = _pose_of(conn.msgtype, msg)
                series.add(header_stamp(msg.header, ns), *pose)
            t, p, q = series.arrays()
            where = f"{bag}:{topic}"
    if len(t) == 0:
        raise BagError(f"{where}: no poses")
    # Trajectory normalises the quaternions; zero or NaN ones raise naming `where`
    return Trajectory(t, p, q, source=where)


class _Identity:
    w, x, y, z = 1.0, 0.0, 0.0, 0.0


_IDENTITY = _Identity()


def _pose_of(msgtype: str, msg: Any) -> tuple[Any, Any]:
    if msgtype == "geometry_msgs/msg/PoseStamped":
        return msg.pose.position, msg.pose.orientation
    if msgtype == "geometry_msgs/msg/TransformStamped":
        return msg.transform.translation, msg.transform.rotation
    if msgtype == "geometry_msgs/msg/PointStamped":
        return msg.point, _IDENTITY
    # PoseWithCovarianceStamped and Odometry: pose.pose
    return msg.pose.pose.position, msg.pose.pose.orientation


def _tf_trajectory(
    reader: Any,
    bag: PathLike,
    topic: str,
    parent_frame: str | None,
    child_frame: str | None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:

    types = topic_types(reader)
    topics = [topic]
    if topic == "/tf" and types.get("/tf_static") == TF_TYPE:
        topics.append("/tf_static")
    conns = [c for c in reader.connections if c.topic in topics]
    edges: dict[tuple[str, str], _Series] = {}
    for conn, ns, raw in bag_messages(reader, bag, conns):
        msg = bag_deserialize(reader, bag, conn, raw)
        for tr in msg.transforms:
            key = (_strip(tr.header.frame_id), _strip(tr.child_frame_id))
            series = edges.setdefault(key, _Series())
            series.static = series.static or conn.topic == "/tf_static"
            series.add(header_stamp(tr.header, ns), tr.transform.translation, tr.transform.rotation)
    pairs = ", ".join(f"{a}->{b}" for a, b in sorted(edges)) or "none"
    if parent_frame is None and child_frame is None:
        dynamic = [k for k, s in edges.items() if not s.static]
        if len(dynamic) != 1:
            raise BagError(
                f"{bag}: {topic} holds {len(dynamic)} moving frame pairs; choose one with "
                f"parent_frame= and child_frame= (frame pairs: {pairs})"
            )
        parent_frame, child_frame = dynamic[0]
    if parent_frame is None or child_frame is None:
        raise BagError(f"{bag}: give both parent_frame and child_frame (frame pairs: {pairs})")
    parent_frame, child_frame = _strip(parent_frame), _strip(child_frame)
    # walk up from the child: tf is a tree, every frame has one parent
    up = {c: (p, s) for (p, c), s in edges.items()}
    chain: list[_Series] = []
    frame = child_frame
    seen = {frame}
    while frame != parent_frame:
        if frame not in up:
            raise BagError(
                f"{bag}: no tf chain from {parent_frame} to {child_frame} in {topic} "
                f"(frame pairs: {pairs})"
            )
        frame, series = up[frame]
        if frame in seen:
            raise BagError(f"{bag}: tf loop through {frame} in {topic}")
        seen.add(frame)
        chain.append(series)
    chain.reverse()  # parent first
    if len(chain) == 1:
        return chain[0].arrays()
    dynamic = [s for s in chain if not s.static]
    base = max(dynamic, key=lambda s: len(s.t)) if dynamic else chain[-1]
    times = base.arrays()[0]
    pos = np.zeros((len(times), 3))
    rot = np.tile([1.0, 0.0, 0.0, 0.0], (len(times), 1))
    ok = np.ones(len(times), bool)
    for series in chain:  # T = T_parent_a * T_a_b * ...
        p, q, good = series.at(times)
        pos = pos + quat_rotate(rot, p)
        rot = quat_multiply(rot, q)
        ok &= good
    return times[ok], pos[ok], rot[ok]
