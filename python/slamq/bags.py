"""Maps and poses straight from ROS bags (ROS1 ``.bag``, ROS2 sqlite3 ``.db3`` and MCAP).

No ROS install is needed: the bags are read with the pure-Python ``rosbags`` package.

- :func:`read_bag_maps` yields every (or every N-th) map published on a
  ``nav_msgs/OccupancyGrid`` topic, with ``map_msgs/OccupancyGridUpdate`` patches (the
  ``<topic>_updates`` topic, e.g. ``/map_updates``) applied onto the last full map.
  Grids are converted with :func:`slamq.maps.from_occupancy_grid` (SPEC.md section 1:
  row 0 of an OccupancyGrid is the bottom row; -1 and values outside 0..100 are unknown).
- :func:`read_last_map` is the last of them (what :func:`slamq.load_map` returns for a bag).
- :func:`read_bag_trajectory` reads a :class:`slamq.trajectory.Trajectory` from
  ``PoseStamped``, ``PoseWithCovarianceStamped``, ``Odometry``, ``TransformStamped``,
  ``nav_msgs/Path`` (its last message) or ``/tf`` (one frame pair, or a chain of frames
  composed through ``/tf`` and ``/tf_static``).

A bag is a ``.bag`` file, a ``.db3`` or ``.mcap`` file, or a ROS2 bag folder holding
``metadata.yaml``. Anything wrong (missing, truncated or corrupt bag, missing topic, wrong
message type) raises :class:`slamq.BagError` naming the bag and the reason.
"""

from __future__ import annotations

import dataclasses
import math
import os
import warnings
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any, Union

import numpy as np

from slamq.errors import BagError, MapError, MapWarning

if TYPE_CHECKING:  # pragma: no cover
    from slamq.maps import OccupancyMap
    from slamq.trajectory import Trajectory

__all__ = [
    "BAG_SUFFIXES",
    "is_bag",
    "bag_topics",
    "read_bag_maps",
    "read_last_map",
    "read_bag_trajectory",
]

PathLike = Union[str, "os.PathLike[str]"]

#: File suffixes read as bags (a folder holding ``metadata.yaml`` is a ROS2 bag too).
BAG_SUFFIXES = (".bag", ".db3", ".mcap")

GRID_TYPE = "nav_msgs/msg/OccupancyGrid"
UPDATE_TYPE = "map_msgs/msg/OccupancyGridUpdate"
PATH_TYPE = "nav_msgs/msg/Path"
TF_TYPE = "tf2_msgs/msg/TFMessage"
POSE_TYPES = (
    "geometry_msgs/msg/PoseStamped",
    "geometry_msgs/msg/PoseWithCovarianceStamped",
    "nav_msgs/msg/Odometry",
    "geometry_msgs/msg/TransformStamped",
    "geometry_msgs/msg/PointStamped",
    PATH_TYPE,
)

# map_msgs is not in every rosbags type store; ROS1 bags embed it, ROS2 bags may not.
_UPDATE_MSGDEF = """\
std_msgs/Header header
int32 x
int32 y
uint32 width
uint32 height
int8[] data
"""


def is_bag(path: PathLike) -> bool:
    """True when ``path`` names a bag: a ``.bag``/``.db3``/``.mcap`` file or a ROS2 folder.

    Examples
    --------
    >>> is_bag("run1.bag"), is_bag("map.yaml")
    (True, False)
    """
    p = Path(path)
    if p.suffix.lower() in BAG_SUFFIXES:
        return True
    return p.is_dir() and (p / "metadata.yaml").is_file()


def _default_typestore() -> Any:
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.LATEST)
    if UPDATE_TYPE not in store.types:
        store.register(get_types_from_msg(_UPDATE_MSGDEF, UPDATE_TYPE))
    return store


def _reason(exc: BaseException) -> str:
    text = " ".join(str(a) for a in exc.args) if exc.args else type(exc).__name__
    return text.strip() or type(exc).__name__


@contextmanager
def _open(bag: PathLike) -> Iterator[Any]:
    """An open ``rosbags`` AnyReader; every failure becomes a :class:`BagError`."""
    from rosbags.highlevel import AnyReader

    path = Path(bag)
    if not path.is_dir() and path.suffix.lower() not in BAG_SUFFIXES:
        raise BagError(f"{path}: not a bag (expected {', '.join(BAG_SUFFIXES)} or a ROS2 folder)")
    if not path.exists():
        raise BagError(f"{path}: no such file or folder")
    if path.is_dir() and not (path / "metadata.yaml").is_file():
        raise BagError(f"{path}: folder is not a ROS2 bag (no metadata.yaml)")
    try:
        reader = AnyReader([path], default_typestore=_default_typestore())
        reader.open()
    except Exception as exc:  # noqa: BLE001 - rosbags raises many types; one clear line
        raise BagError(
            f"{path}: cannot open bag (truncated or corrupt?): {_reason(exc)}"
        ) from None
    try:
        if UPDATE_TYPE not in reader.typestore.types:  # a bag with partial definitions
            from rosbags.typesys import get_types_from_msg

            try:
                reader.typestore.register(get_types_from_msg(_UPDATE_MSGDEF, UPDATE_TYPE))
            except Exception:  # noqa: BLE001, S110 - only needed when the bag has updates
                pass
        yield reader
    finally:
        try:
            reader.close()
        except Exception:  # noqa: BLE001, S110 - closing a damaged bag may fail too
            pass


def _messages(reader: Any, path: PathLike, connections: list) -> Iterator[tuple[Any, int, Any]]:
    """``(connection, bag time ns, raw bytes)``; read failures become :class:`BagError`."""
    it = reader.messages(connections=connections)
    while True:
        try:
            item = next(it)
        except StopIteration:
            return
        except Exception as exc:  # noqa: BLE001
            raise BagError(
                f"{path}: cannot read messages (truncated or corrupt bag?): {_reason(exc)}"
            ) from None
        yield item


def _deserialize(reader: Any, path: PathLike, conn: Any, raw: Any) -> Any:
    try:
        return reader.deserialize(raw, conn.msgtype)
    except Exception as exc:  # noqa: BLE001
        raise BagError(
            f"{path}: cannot decode a {conn.msgtype} message on {conn.topic}: {_reason(exc)}"
        ) from None


def _topic_types(reader: Any) -> dict[str, str]:
    return {c.topic: c.msgtype for c in reader.connections}


def _describe_topics(types: dict[str, str]) -> str:
    if not types:
        return "the bag has no topics"
    return "topics in the bag: " + ", ".join(f"{t} ({m})" for t, m in sorted(types.items()))


def bag_topics(bag: PathLike) -> dict[str, str]:
    """Every topic of a bag and its message type (ROS2 style, ``pkg/msg/Type``).

    Examples
    --------
    >>> bag_topics("run1.bag")  # doctest: +SKIP
    {'/map': 'nav_msgs/msg/OccupancyGrid', '/tf': 'tf2_msgs/msg/TFMessage'}
    >>> bag_topics("missing.bag")
    Traceback (most recent call last):
    ...
    slamq.errors.BagError: missing.bag: no such file or folder
    """
    with _open(bag) as reader:
        return _topic_types(reader)


def _connections(reader: Any, path: PathLike, topic: str, msgtypes: tuple[str, ...]) -> list:
    types = _topic_types(reader)
    conns = [c for c in reader.connections if c.topic == topic]
    if not conns:
        raise BagError(f"{path}: no topic {topic}; {_describe_topics(types)}")
    wrong = sorted({c.msgtype for c in conns if c.msgtype not in msgtypes})
    if wrong:
        raise BagError(
            f"{path}: topic {topic} carries {', '.join(wrong)}, expected "
            + " or ".join(msgtypes)
        )
    return conns


def _stamp(header: Any, bag_ns: int) -> float:
    """Header stamp in seconds; the bag's receive time when the stamp is zero."""
    stamp = header.stamp
    sec, nsec = int(stamp.sec), int(stamp.nanosec)
    if sec == 0 and nsec == 0:
        return bag_ns * 1e-9
    return sec + nsec * 1e-9


def _yaw(q: Any) -> float:
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


@dataclasses.dataclass
class _Grid:
    """An OccupancyGrid's state: the int8 cells (row 0 = bottom) and its metadata."""

    cells: np.ndarray  # (height, width) int8
    resolution: float
    origin: tuple[float, float, float]
    frame_id: str
    stamp: float

    @classmethod
    def from_msg(cls, msg: Any, bag_ns: int, path: PathLike, topic: str) -> _Grid:
        info = msg.info
        width, height = int(info.width), int(info.height)
        data = np.asarray(msg.data).astype(np.int8, copy=False).reshape(-1)
        if data.size != width * height:
            raise BagError(
                f"{path}: {topic} message holds {data.size} cells, "
                f"width*height = {width}*{height} = {width * height}"
            )
        o = info.origin
        origin = (float(o.position.x), float(o.position.y), _yaw(o.orientation))
        return cls(
            cells=data.reshape(height, width).copy(),
            resolution=float(info.resolution),
            origin=origin,
            frame_id=str(msg.header.frame_id),
            stamp=_stamp(msg.header, bag_ns),
        )

    def apply(self, upd: Any, bag_ns: int, path: PathLike, topic: str) -> bool:
        """Paste an OccupancyGridUpdate patch (x, y = column, row of its lower-left cell).

        A patch that does not fit the map (it was meant for a full map of another size,
        e.g. received just before the enlarged map) or whose data is not width x height
        cells is skipped with a :class:`slamq.MapWarning`, as rviz and nav2's static
        layer ignore it; returns whether the patch was applied.
        """
        x, y, w, h = int(upd.x), int(upd.y), int(upd.width), int(upd.height)
        data = np.asarray(upd.data).astype(np.int8, copy=False).reshape(-1)
        height, width = self.cells.shape
        problem = None
        if data.size != w * h:
            problem = f"holds {data.size} cells, width*height = {w}*{h} = {w * h}"
        elif x < 0 or y < 0 or x + w > width or y + h > height:
            problem = f"x={x} y={y} {w}x{h} lies outside the {width}x{height} map"
        if problem is not None:
            warnings.warn(
                MapWarning(f"{path}: skipped a {topic} update at {_stamp(upd.header, bag_ns):.3f}"
                           f" s: it {problem}"),
                stacklevel=2,
            )
            return False
        self.cells[y : y + h, x : x + w] = data.reshape(h, w)
        self.stamp = _stamp(upd.header, bag_ns)
        return True

    def to_map(self, path: PathLike, topic: str, index: int) -> OccupancyMap:
        from slamq.maps import from_occupancy_grid

        source = f"{path}:{topic}[{index}]"
        try:
            m = from_occupancy_grid(
                self.cells,
                resolution=self.resolution,
                origin=self.origin,
                source=source,
            )
        except BagError:
            raise
        except MapError as exc:
            raise BagError(str(exc) if source in str(exc) else f"{source}: {exc}") from None
        meta = dict(m.meta)
        meta.update(
            bag=str(path), topic=topic, index=index, stamp=self.stamp, frame_id=self.frame_id
        )
        return dataclasses.replace(m, meta=meta)


def _decode_grid(reader: Any, bag: PathLike, topic: str, item: tuple[Any, int, Any]) -> _Grid:
    conn, ns, raw = item
    return _Grid.from_msg(_deserialize(reader, bag, conn, raw), ns, bag, topic)


def read_bag_maps(
    bag: PathLike,
    topic: str = "/map",
    every: int = 1,
    *,
    updates: bool | str = True,
    include_last: bool = False,
) -> Iterator[tuple[float, OccupancyMap]]:
    """Yield ``(timestamp_seconds, OccupancyMap)`` for the maps of a bag, in bag order.

    Parameters
    ----------
    bag : path
        ROS1 ``.bag``, ROS2 ``.db3`` / ``.mcap`` file, or ROS2 bag folder.
    topic : str, default "/map"
        A ``nav_msgs/OccupancyGrid`` topic.
    every : int, default 1
        Keep maps number 0, N, 2N, ... (counting every full map and every applied update).
    updates : bool or str, default True
        Apply ``map_msgs/OccupancyGridUpdate`` patches from ``<topic>_updates`` when the bag
        has that topic (a string names another update topic; False ignores updates). Each
        applied patch is a new map in the sequence; patches before the first full map are
        skipped, and so are patches that do not fit the map (with a ``MapWarning``).
    include_last : bool, default False
        Also yield the last map when ``every`` skipped it.

    Yields
    ------
    (float, OccupancyMap)
        The header stamp in seconds (the bag time when the stamp is zero) and the map,
        held image-style; ``map.meta`` has ``bag``, ``topic``, ``index``, ``stamp`` and
        ``frame_id``.

    Raises
    ------
    BagError
        Missing/truncated/corrupt bag, no such topic (the message lists the topics), wrong
        message type.

    Examples
    --------
    >>> for t, m in read_bag_maps("run1.bag", every=10):  # doctest: +SKIP
    ...     print(f"{t:.1f}", m.shape)
    >>> next(read_bag_maps("map.yaml"))
    Traceback (most recent call last):
    ...
    slamq.errors.BagError: map.yaml: not a bag (expected .bag, .db3, .mcap or a ROS2 folder)
    """
    if isinstance(every, bool) or not isinstance(every, int) or every < 1:
        raise BagError(f"{bag}: every must be a positive integer, got {every!r}")
    with _open(bag) as reader:
        conns = _connections(reader, bag, topic, (GRID_TYPE,))
        update_topic: str | None = None
        if updates:
            update_topic = updates if isinstance(updates, str) else topic + "_updates"
            types = _topic_types(reader)
            if update_topic not in types:
                if isinstance(updates, str):
                    raise BagError(
                        f"{bag}: no topic {update_topic}; {_describe_topics(types)}"
                    )
                update_topic = None
            else:
                conns = conns + _connections(reader, bag, update_topic, (UPDATE_TYPE,))
        index = -1
        grid: _Grid | None = None  # decoded state (needed when updates arrive)
        pending: tuple[Any, int, Any] | None = None  # last full map, not decoded yet
        last_yielded = -1
        for conn, ns, raw in _messages(reader, bag, conns):
            if conn.topic == topic:
                pending, grid = (conn, ns, raw), None
            else:
                if pending is None and grid is None:
                    continue
                if grid is None:
                    assert pending is not None
                    grid = _decode_grid(reader, bag, topic, pending)
                    pending = None
                if not grid.apply(_deserialize(reader, bag, conn, raw), ns, bag, conn.topic):
                    continue
            index += 1
            if index % every == 0:
                if grid is None:
                    assert pending is not None
                    current = _decode_grid(reader, bag, topic, pending)
                else:
                    current = grid
                last_yielded = index
                yield current.stamp, current.to_map(bag, topic, index)
        if index < 0:
            raise BagError(f"{bag}: topic {topic} has no messages")
        if include_last and last_yielded != index:
            if grid is None:
                assert pending is not None
                grid = _decode_grid(reader, bag, topic, pending)
            yield grid.stamp, grid.to_map(bag, topic, index)


def read_last_map(bag: PathLike, topic: str = "/map") -> OccupancyMap:
    """The last map of a bag (with ``<topic>_updates`` patches applied).

    Only the last full map and the patches after it are decoded.

    Examples
    --------
    >>> m = read_last_map("run1.bag")  # doctest: +SKIP
    >>> m.meta["topic"], m.meta["stamp"]  # doctest: +SKIP
    ('/map', 1503324571.12)
    >>> read_last_map("missing.mcap")
    Traceback (most recent call last):
    ...
    slamq.errors.BagError: missing.mcap: no such file or folder
    """
    last = None
    # every=huge: only map 0 is decoded on the way; include_last decodes the final one.
    for _, m in read_bag_maps(bag, topic, every=2**62, include_last=True):
        last = m
    assert last is not None
    return last


# ----------------------------------------------------------------------------- poses


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
    slamq.trajectory.Trajectory
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
    from slamq.trajectory import Trajectory

    if topic is not None and ":" in topic:  # "/tf:map->base_link", or evo's "/tf:map.base_link"
        topic, _, frames = topic.partition(":")
        parent, _, child = frames.partition("->" if "->" in frames else ".")
        parent_frame = parent_frame or parent.strip() or None
        child_frame = child_frame or child.strip() or None
    with _open(bag) as reader:
        types = _topic_types(reader)
        if topic is None:
            candidates = sorted(t for t, m in types.items() if m in POSE_TYPES)
            if len(candidates) == 1:
                topic = candidates[0]
            elif not candidates and "/tf" in types:
                topic = "/tf"
            elif not candidates:
                raise BagError(f"{bag}: no pose topic; {_describe_topics(types)}")
            else:
                raise BagError(
                    f"{bag}: several pose topics ({', '.join(candidates)}); name one with topic="
                )
        if topic not in types:
            raise BagError(f"{bag}: no topic {topic}; {_describe_topics(types)}")
        msgtype = types[topic]
        if msgtype == TF_TYPE:
            t, p, q = _tf_trajectory(reader, bag, topic, parent_frame, child_frame)
            where = f"{bag}:{topic}:{parent_frame or ''}->{child_frame or ''}"
        else:
            conns = _connections(reader, bag, topic, POSE_TYPES)
            series = _Series()
            for conn, ns, raw in _messages(reader, bag, conns):
                msg = _deserialize(reader, bag, conn, raw)
                if conn.msgtype == PATH_TYPE:
                    series = _Series()
                    for ps in msg.poses:
                        series.add(_stamp(ps.header, ns), ps.pose.position, ps.pose.orientation)
                    continue
                pose = _pose_of(conn.msgtype, msg)
                series.add(_stamp(msg.header, ns), *pose)
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
    from slamq.trajectory.model import quat_multiply, quat_rotate

    types = _topic_types(reader)
    topics = [topic]
    if topic == "/tf" and types.get("/tf_static") == TF_TYPE:
        topics.append("/tf_static")
    conns = [c for c in reader.connections if c.topic in topics]
    edges: dict[tuple[str, str], _Series] = {}
    for conn, ns, raw in _messages(reader, bag, conns):
        msg = _deserialize(reader, bag, conn, raw)
        for tr in msg.transforms:
            key = (_strip(tr.header.frame_id), _strip(tr.child_frame_id))
            series = edges.setdefault(key, _Series())
            series.static = series.static or conn.topic == "/tf_static"
            series.add(_stamp(tr.header, ns), tr.transform.translation, tr.transform.rotation)
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
