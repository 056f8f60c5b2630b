"""ROS bag writers (ROS 1 ``.bag``, ROS 2 sqlite3 and MCAP) through the ``rosbags`` library
(the ``bags`` extra: ``pip install 'slamq[bags]'``).

Every bag holds, at each scan's stamp (``epoch + seq.stamps``, valid ROS times):

* ``/clock`` (``rosgraph_msgs/Clock``), for ``use_sim_time``;
* ``/tf`` (``tf2_msgs/TFMessage``): ``odom -> base_link`` from the odometry; in a ROS 1
  bag also ``base_link -> laser`` (repeated, as ROS 1 has no latched static topic in a
  bag's playback); in ROS 2 bags ``base_link -> laser`` is one message on ``/tf_static``
  (transient-local durability, as ``robot_state_publisher`` offers it);
* ``/odom`` (``nav_msgs/Odometry``, ``odom -> base_link``, with the step's velocities);
* ``/scan`` (``sensor_msgs/LaserScan``, frame ``laser``; ``+inf`` = no return, REP 117).

The ground truth is not in the bags (a SLAM node must not see it).
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from slamq.errors import SlamqError
from slamq.synth.recording import Recording
from slamq.synth.writers.rawlog import EPOCH

__all__ = ["FRAMES", "write_rosbag1", "write_rosbag2", "write_mcap"]

#: Frame names: ``odom``, ``base_link``, ``laser``.
FRAMES = {"odom": "odom", "base": "base_link", "laser": "laser"}

_TF = "tf2_msgs/msg/TFMessage"
_TF_MSGDEF = "geometry_msgs/TransformStamped[] transforms"
_TYPES = {"/clock": "rosgraph_msgs/msg/Clock", "/tf": _TF, "/tf_static": _TF,
          "/odom": "nav_msgs/msg/Odometry", "/scan": "sensor_msgs/msg/LaserScan"}


def _typestore(ros1: bool) -> Any:
    try:
        from rosbags.typesys import Stores, get_types_from_msg, get_typestore
    except ImportError:
        raise SlamqError("writing ROS bags needs the 'bags' extra (rosbags): "
                         "pip install 'slamq[bags]'") from None
    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    if _TF not in store.types:  # the Noetic store lacks tf2_msgs
        store.register(get_types_from_msg(_TF_MSGDEF, _TF))
    return store


def _messages(seq: Recording, store: Any, ros1: bool, epoch: float
              ) -> Iterator[tuple[str, int, Any]]:
    """``(topic, stamp ns, message)`` in time order."""
    T = store.types
    Time, Header = T["builtin_interfaces/msg/Time"], T["std_msgs/msg/Header"]
    Vec, Quat = T["geometry_msgs/msg/Vector3"], T["geometry_msgs/msg/Quaternion"]
    Transform, TFStamped = T["geometry_msgs/msg/Transform"], T["geometry_msgs/msg/TransformStamped"]
    TFMessage = T[_TF]
    Point, Pose = T["geometry_msgs/msg/Point"], T["geometry_msgs/msg/Pose"]
    PoseCov, Twist = T["geometry_msgs/msg/PoseWithCovariance"], T["geometry_msgs/msg/Twist"]
    TwistCov, Odometry = T["geometry_msgs/msg/TwistWithCovariance"], T["nav_msgs/msg/Odometry"]
    Clock, LaserScan = T["rosgraph_msgs/msg/Clock"], T["sensor_msgs/msg/LaserScan"]
    laser = seq.laser
    n = len(seq)
    # integer nanoseconds from the epoch's integer seconds: exact, monotonic
    sec0 = math.floor(epoch)
    ns = (np.round((epoch - sec0 + np.asarray(seq.stamps, np.float64)) * 1e9).astype(np.int64)
          + sec0 * 1_000_000_000)
    odom = np.asarray(seq.odom, np.float64)
    vx = np.zeros(n)
    wz = np.zeros(n)
    if n > 1:
        dt = np.diff(ns) * 1e-9
        c, s = np.cos(odom[:-1, 2]), np.sin(odom[:-1, 2])
        d = np.diff(odom[:, :2], axis=0)
        vx[1:] = (c * d[:, 0] + s * d[:, 1]) / dt
        wz[1:] = np.angle(np.exp(1j * np.diff(odom[:, 2]))) / dt
    scan_time = float(np.median(np.diff(seq.stamps))) if n > 1 else 0.0
    ranges = np.asarray(seq.ranges, np.float32)
    zero36 = np.zeros(36, np.float64)
    no_intensity = np.zeros(0, np.float32)
    ox, oy, oth = map(float, laser.offset)

    def stamp(t: int) -> Any:
        return Time(sec=int(t // 1_000_000_000), nanosec=int(t % 1_000_000_000))

    def header(t: int, frame: str) -> Any:
        return Header(seq=0, stamp=stamp(t), frame_id=frame) if ros1 else Header(
            stamp=stamp(t), frame_id=frame)

    def quat(yaw: float) -> Any:
        return Quat(x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2))

    def tf(t: int, parent: str, child: str, x: float, y: float, yaw: float) -> Any:
        return TFStamped(header=header(t, parent), child_frame_id=child,
                         transform=Transform(translation=Vec(x=x, y=y, z=0.0),
                                             rotation=quat(yaw)))

    def laser_tf(t: int) -> Any:
        return tf(t, FRAMES["base"], FRAMES["laser"], ox, oy, oth)

    if not ros1 and n:
        yield "/tf_static", int(ns[0]), TFMessage(transforms=[laser_tf(int(ns[0]))])
    for i in range(n):
        t = int(ns[i])
        x, y, yaw = map(float, odom[i])
        yield "/clock", t, Clock(clock=stamp(t))
        transforms = [tf(t, FRAMES["odom"], FRAMES["base"], x, y, yaw)]
        if ros1:
            transforms.append(laser_tf(t))
        yield "/tf", t, TFMessage(transforms=transforms)
        yield "/odom", t, Odometry(
            header=header(t, FRAMES["odom"]), child_frame_id=FRAMES["base"],
            pose=PoseCov(pose=Pose(position=Point(x=x, y=y, z=0.0), orientation=quat(yaw)),
                         covariance=zero36),
            twist=TwistCov(twist=Twist(linear=Vec(x=float(vx[i]), y=0.0, z=0.0),
                                       angular=Vec(x=0.0, y=0.0, z=float(wz[i]))),
                           covariance=zero36))
        yield "/scan", t, LaserScan(
            header=header(t, FRAMES["laser"]), angle_min=laser.angle_min,
            angle_max=laser.angle_min + laser.angle_increment * (laser.beams - 1),
            angle_increment=laser.angle_increment, time_increment=0.0, scan_time=scan_time,
            range_min=laser.min_range, range_max=laser.max_range, ranges=ranges[i],
            intensities=no_intensity)


def _fail(path: Path, exc: BaseException) -> SlamqError:
    return SlamqError(f"{path}: cannot write the bag ({exc})")


def write_rosbag1(seq: Recording, path: str | Path, *, epoch: float = EPOCH) -> Path:
    """Write a sequence as a ROS 1 bag (``/clock``, ``/tf``, ``/odom``, ``/scan``).

    Parameters
    ----------
    seq : Recording
    path : path
        The ``.bag`` file (replaced if it exists).
    epoch : float, default :data:`~slamq.synth.writers.EPOCH`
        Unix time of the sequence's time 0.

    Returns
    -------
    pathlib.Path

    Examples
    --------
    >>> import tempfile, pathlib, numpy as np
    >>> from slamq.models import OccupancyMap
    >>> from slamq.synth import LaserSpec, Recording
    >>> world = OccupancyMap(np.full((4, 4), 254, np.uint8), np.zeros((4, 4), bool), 0.1)
    >>> seq = Recording(np.array([0.0, 0.1]), np.zeros((2, 3)), np.zeros((2, 3)),
    ...                np.ones((2, 3), np.float32), LaserSpec(beams=3), world)
    >>> write_rosbag1(seq, pathlib.Path(tempfile.mkdtemp()) / "s.bag").suffix
    '.bag'
    """
    from rosbags.rosbag1 import Writer

    path = Path(path)
    store = _typestore(True)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.unlink(missing_ok=True)
        with Writer(path) as writer:
            conns = {topic: writer.add_connection(topic, msgtype, typestore=store)
                     for topic, msgtype in _TYPES.items() if topic != "/tf_static"}
            for topic, t, msg in _messages(seq, store, True, epoch):
                writer.write(conns[topic], t, store.serialize_ros1(msg, _TYPES[topic]))
    except OSError as exc:
        raise _fail(path, exc) from exc
    return path


def _write2(seq: Recording, folder: Path, epoch: float, mcap: bool) -> Path:
    import shutil

    from rosbags.interfaces import (
        Qos,
        QosDurability,
        QosHistory,
        QosLiveliness,
        QosReliability,
        QosTime,
    )
    from rosbags.rosbag2 import StoragePlugin, Writer

    folder = Path(folder)
    store = _typestore(False)
    never = QosTime(sec=0, nsec=0)
    static = Qos(QosHistory.KEEP_LAST, 1, QosReliability.RELIABLE, QosDurability.TRANSIENT_LOCAL,
                 never, never, QosLiveliness.AUTOMATIC, never, False)
    try:
        if folder.exists():
            shutil.rmtree(folder)
        folder.parent.mkdir(parents=True, exist_ok=True)
        plugin = StoragePlugin.MCAP if mcap else StoragePlugin.SQLITE3
        with Writer(folder, version=9, storage_plugin=plugin) as writer:
            conns = {topic: writer.add_connection(
                topic, msgtype, typestore=store,
                offered_qos_profiles=[static] if topic == "/tf_static" else ())
                for topic, msgtype in _TYPES.items()}
            for topic, t, msg in _messages(seq, store, False, epoch):
                writer.write(conns[topic], t, store.serialize_cdr(msg, _TYPES[topic]))
    except OSError as exc:
        raise _fail(folder, exc) from exc
    return folder


def write_rosbag2(seq: Recording, folder: str | Path, *, epoch: float = EPOCH) -> Path:
    """Write a sequence as a ROS 2 bag, sqlite3 storage (``/clock``, ``/tf``,
    ``/tf_static``, ``/odom``, ``/scan``).

    Parameters
    ----------
    seq : Recording
    folder : path
        The bag folder (``metadata.yaml`` + ``<name>_0.db3``; replaced if it exists).
    epoch : float, default :data:`~slamq.synth.writers.EPOCH`

    Returns
    -------
    pathlib.Path

    Examples
    --------
    >>> import tempfile, pathlib, numpy as np
    >>> from slamq.models import OccupancyMap
    >>> from slamq.synth import LaserSpec, Recording
    >>> world = OccupancyMap(np.full((4, 4), 254, np.uint8), np.zeros((4, 4), bool), 0.1)
    >>> seq = Recording(np.array([0.0, 0.1]), np.zeros((2, 3)), np.zeros((2, 3)),
    ...                np.ones((2, 3), np.float32), LaserSpec(beams=3), world)
    >>> p = write_rosbag2(seq, pathlib.Path(tempfile.mkdtemp()) / "s")
    >>> sorted(f.suffix for f in p.iterdir())
    ['.db3', '.yaml']
    """
    return _write2(seq, Path(folder), epoch, mcap=False)


def write_mcap(seq: Recording, folder: str | Path, *, epoch: float = EPOCH) -> Path:
    """Write a sequence as a ROS 2 bag with MCAP storage (the same topics as
    :func:`write_rosbag2`).

    Parameters
    ----------
    seq : Recording
    folder : path
        The bag folder (``metadata.yaml`` + ``<name>_0.mcap``; replaced if it exists).
    epoch : float, default :data:`~slamq.synth.writers.EPOCH`

    Returns
    -------
    pathlib.Path

    Examples
    --------
    >>> import tempfile, pathlib, numpy as np
    >>> from slamq.models import OccupancyMap
    >>> from slamq.synth import LaserSpec, Recording
    >>> world = OccupancyMap(np.full((4, 4), 254, np.uint8), np.zeros((4, 4), bool), 0.1)
    >>> seq = Recording(np.array([0.0, 0.1]), np.zeros((2, 3)), np.zeros((2, 3)),
    ...                np.ones((2, 3), np.float32), LaserSpec(beams=3), world)
    >>> p = write_mcap(seq, pathlib.Path(tempfile.mkdtemp()) / "s")
    >>> sorted(f.suffix for f in p.iterdir())
    ['.mcap', '.yaml']
    """
    return _write2(seq, Path(folder), epoch, mcap=True)
