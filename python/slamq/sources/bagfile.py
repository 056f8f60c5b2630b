"""Maps and poses straight from ROS bags (ROS1 ``.bag``, ROS2 sqlite3 ``.db3`` and MCAP).

No ROS install is needed: the bags are read with the pure-Python ``rosbags`` package.

- :func:`read_bag_maps` yields every (or every N-th) map published on a
  ``nav_msgs/OccupancyGrid`` topic, with ``map_msgs/OccupancyGridUpdate`` patches (the
  ``<topic>_updates`` topic, e.g. ``/map_updates``) applied onto the last full map.
  Grids are converted with :func:`slamq.sources.from_occupancy_grid` (docs/spec.md section 1:
  row 0 of an OccupancyGrid is the bottom row; -1 and values outside 0..100 are unknown).
- :func:`read_last_map` is the last of them (what :func:`slamq.load_map` returns for a bag).
- :func:`read_bag_trajectory` reads a :class:`slamq.Trajectory` from
  ``PoseStamped``, ``PoseWithCovarianceStamped``, ``Odometry``, ``TransformStamped``,
  ``nav_msgs/Path`` (its last message) or ``/tf`` (one frame pair, or a chain of frames
  composed through ``/tf`` and ``/tf_static``).

A bag is a ``.bag`` file, a ``.db3`` or ``.mcap`` file, or a ROS2 bag folder holding
``metadata.yaml``. Anything wrong (missing, truncated or corrupt bag, missing topic, wrong
message type) raises :class:`slamq.BagError` naming the bag and the reason.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from slamq.errors import BagError
from slamq.sources.files import BAG_SUFFIXES, PathLike

__all__ = ["bag_topics"]

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


def _default_typestore() -> Any:
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.LATEST)
    if UPDATE_TYPE not in store.types:
        store.register(get_types_from_msg(_UPDATE_MSGDEF, UPDATE_TYPE))
    return store


def _reason(exc: BaseException, limit: int = 160) -> str:
    """A library exception as one short line: a decoder's message can carry the whole raw
    message (megabytes of bytes), which an error message never prints.

    Examples
    --------
    >>> _reason(ValueError("bad bytes: " + "x" * 500))[-30:]
    'xxxxxxxxxx... (511 characters)'
    """
    text = " ".join(str(a) for a in exc.args) if exc.args else type(exc).__name__
    text = " ".join(text.split()) or type(exc).__name__
    return text if len(text) <= limit else f"{text[:limit]}... ({len(text)} characters)"


@contextmanager
def open_bag(bag: PathLike) -> Iterator[Any]:
    """An open ``rosbags`` AnyReader; every failure becomes a :class:`BagError`."""
    try:
        from rosbags.highlevel import AnyReader
    except ImportError:
        raise BagError(f"{bag}: reading ROS bags needs the 'bags' extra (rosbags): "
                       "pip install 'slamq[bags]'") from None

    path = Path(bag)
    if not path.is_dir() and path.suffix.lower() not in BAG_SUFFIXES:
        raise BagError(f"{path}: not a bag (expected {', '.join(BAG_SUFFIXES)} or a ROS2 folder)")
    if not path.exists():
        raise BagError(f"{path}: no such file or folder")
    if path.is_dir() and not (path / "metadata.yaml").is_file():
        raise BagError(f"{path}: folder is not a ROS2 bag (no metadata.yaml)")
    from slamq.sources.bagchunks import check_compressed_chunks

    check_compressed_chunks(path)  # before rosbags inflates a chunk whole
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


def bag_messages(reader: Any, path: PathLike, connections: list) -> Iterator[tuple[Any, int, Any]]:
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


def bag_deserialize(reader: Any, path: PathLike, conn: Any, raw: Any) -> Any:
    try:
        return reader.deserialize(raw, conn.msgtype)
    except Exception as exc:  # noqa: BLE001
        raise BagError(
            f"{path}: cannot decode a {conn.msgtype} message on {conn.topic}: {_reason(exc)}"
        ) from None


def topic_types(reader: Any) -> dict[str, str]:
    return {c.topic: c.msgtype for c in reader.connections}


def describe_topics(types: dict[str, str]) -> str:
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
    with open_bag(bag) as reader:
        return topic_types(reader)


def bag_connections(reader: Any, path: PathLike, topic: str, msgtypes: tuple[str, ...]) -> list:
    types = topic_types(reader)
    conns = [c for c in reader.connections if c.topic == topic]
    if not conns:
        raise BagError(f"{path}: no topic {topic}; {describe_topics(types)}")
    wrong = sorted({c.msgtype for c in conns if c.msgtype not in msgtypes})
    if wrong:
        raise BagError(
            f"{path}: topic {topic} carries {', '.join(wrong)}, expected "
            + " or ".join(msgtypes)
        )
    return conns


def header_stamp(header: Any, bag_ns: int) -> float:
    """Header stamp in seconds; the bag's receive time when the stamp is zero."""
    stamp = header.stamp
    sec, nsec = int(stamp.sec), int(stamp.nanosec)
    if sec == 0 and nsec == 0:
        return bag_ns * 1e-9
    return sec + nsec * 1e-9


def quat_yaw(q: Any) -> float:
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))
