"""ROS bags (ROS1, ROS2 sqlite3, MCAP) written here with the rosbags writer, read back."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from _bagdata import (
    FORMATS,
    BagWriter,
    asymmetric_grid,
    bag_path,
    expected_values,
    room_grid,
)

import slamq
from slamq import BagError
from slamq.sources.bag_maps import read_bag_maps, read_last_map
from slamq.sources.bag_poses import read_bag_trajectory
from slamq.sources.bagfile import bag_topics
from slamq.sources.files import is_bag

GRID = "nav_msgs/msg/OccupancyGrid"
UPDATE = "map_msgs/msg/OccupancyGridUpdate"


def write_maps(path: Path, fmt: str, grids, times, *, origin=(1.5, -2.0, 0.0), res=0.05,
               topic="/map"):
    with BagWriter(path, fmt) as w:
        for t, g in zip(times, grids):
            w.write(topic, GRID, w.grid(t, g, resolution=res, origin=origin))
    return path


@pytest.mark.parametrize("fmt", FORMATS)
def test_round_trip_and_row_flip(tmp_path, fmt):
    grids = [asymmetric_grid(seed=s) for s in range(3)]
    times = [10.25, 11.5, 12.75]
    bag = write_maps(bag_path(tmp_path, fmt), fmt, grids, times, origin=(1.5, -2.0, 0.3))
    assert is_bag(bag)
    got = list(read_bag_maps(bag))
    assert [t for t, _ in got] == pytest.approx(times, abs=1e-9)
    for g, (_, m) in zip(grids, got):
        v, unknown = expected_values(g)
        assert m.shape == g.shape
        np.testing.assert_array_equal(m.unknown, unknown)
        np.testing.assert_array_equal(m.values[~unknown], v[~unknown])
        # the message's first row is the map's bottom row: image row 0 is the occupied one
        assert (m.values[0] == 0).all() and (m.values[-1] == 255).all()
        assert m.resolution == pytest.approx(0.05)
        assert m.origin == pytest.approx((1.5, -2.0, 0.3))
        assert m.meta["topic"] == "/map" and m.meta["frame_id"] == "map"
    assert bag_topics(bag) == {"/map": GRID}


@pytest.mark.parametrize("fmt", FORMATS)
def test_map_updates_are_pasted_bottom_first(tmp_path, fmt):
    base = np.full((5, 7), -1, np.int8)  # image-style
    bag = bag_path(tmp_path, fmt)
    with BagWriter(bag, fmt) as w:
        w.write("/map_updates", UPDATE, w.update(0.5, 0, 0, np.zeros((1, 1))))  # before any map
        w.write("/map", GRID, w.grid(1.0, base))
        # patch at x=1, y=0: 3 wide, 2 high, message order (first row = lowest y)
        w.write("/map_updates", UPDATE, w.update(2.0, 1, 0, [[100, 100, 100], [0, 0, 0]]))
        w.write("/map_updates", UPDATE, w.update(3.0, 6, 4, [[50]]))
    got = list(read_bag_maps(bag))
    assert [t for t, _ in got] == [1.0, 2.0, 3.0]
    assert got[0][1].unknown.all()
    last = got[-1][1]
    # y=0 is the bottom image row (index 4), y=1 the one above it
    assert (last.values[4, 1:4] == 0).all() and not last.unknown[4, 1:4].any()
    assert (last.values[3, 1:4] == 255).all() and not last.unknown[3, 1:4].any()
    assert last.values[0, 6] == 128 and not last.unknown[0, 6]  # rint(127.5) = 128
    assert last.unknown.sum() == 35 - 7
    # earlier maps are not changed by later patches
    assert got[1][1].unknown[0, 6] and got[1][1].unknown.sum() == 35 - 6
    np.testing.assert_array_equal(read_last_map(bag).values, last.values)
    np.testing.assert_array_equal(read_last_map(bag).unknown, last.unknown)
    # updates=False ignores them
    assert len(list(read_bag_maps(bag, updates=False))) == 1


def test_update_outside_the_map_is_skipped_with_a_warning(tmp_path):
    """As rviz and nav2 do: a patch for a map of another size is dropped, the rest kept."""
    bag = bag_path(tmp_path, "ros1")
    with BagWriter(bag, "ros1") as w:
        w.write("/map", GRID, w.grid(1.0, np.zeros((3, 3), np.int8)))
        w.write("/map_updates", UPDATE, w.update(2.0, 2, 2, np.zeros((2, 2))))
        w.write("/map_updates", UPDATE, w.update(2.5, -1, 0, np.zeros((1, 1))))
        w.write("/map_updates", UPDATE, w.update(3.0, 0, 0, np.full((1, 1), 100)))
    with pytest.warns(slamq.MapWarning) as caught:
        got = list(read_bag_maps(bag))
    msgs = [str(c.message) for c in caught]
    assert len(msgs) == 2 and all(bag.name in m for m in msgs)
    assert "x=2 y=2 2x2 lies outside the 3x3 map" in msgs[0] and "x=-1" in msgs[1]
    assert [t for t, _ in got] == [1.0, 3.0]
    assert [m.meta["index"] for _, m in got] == [0, 1]
    assert got[-1][1].values[2, 0] == 0 and (got[-1][1].values[:2] == 255).all()


def test_every_and_include_last(tmp_path):
    grids = [np.full((4, 4), i * 10, np.int8) for i in range(7)]
    bag = write_maps(bag_path(tmp_path, "mcap"), "mcap", grids, [float(i + 1) for i in range(7)])
    assert [m.meta["index"] for _, m in read_bag_maps(bag, every=3)] == [0, 3, 6]
    assert [t for t, _ in read_bag_maps(bag, every=4)] == [1.0, 5.0]
    picked = list(read_bag_maps(bag, every=4, include_last=True))
    assert [m.meta["index"] for _, m in picked] == [0, 4, 6]
    v, _ = expected_values(grids[6])
    np.testing.assert_array_equal(picked[-1][1].values, v)
    np.testing.assert_array_equal(read_last_map(bag).values, v)
    with pytest.raises(BagError, match="every must be a positive integer"):
        list(read_bag_maps(bag, every=0))


@pytest.mark.parametrize("fmt", FORMATS)
@pytest.mark.parametrize(
    "name", ["utexas_gdc_large/intel_lab/intel.yaml", "ros_whill_arc/gmapping.yaml"]
)
def test_maps_from_test_data_and_load_map_dispatch(tmp_path, test_data, fmt, name):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a fixture's YAML names an absolute image path
        src = slamq.load_map(test_data / name)
    g = np.where(src.unknown, -1, np.rint(100 - src.values / 2.55)).astype(np.int8)
    early = np.where(np.arange(g.shape[0])[:, None] < g.shape[0] // 2, g, -1).astype(np.int8)
    bag = write_maps(bag_path(tmp_path, fmt), fmt, [early, g], [3.0, 4.0],
                     origin=src.origin, res=src.resolution)
    m = slamq.load_map(bag)  # the last map on /map
    v, unknown = expected_values(g)
    np.testing.assert_array_equal(m.unknown, src.unknown)
    np.testing.assert_array_equal(m.values[~unknown], v[~unknown])
    assert m.origin == pytest.approx(src.origin) and m.resolution == pytest.approx(src.resolution)
    assert m.meta["index"] == 1 and m.meta["stamp"] == 4.0


@pytest.mark.parametrize("fmt", FORMATS)
def test_truncated_bag(tmp_path, fmt):
    bag = write_maps(bag_path(tmp_path, fmt), fmt, [room_grid()] * 20, np.arange(20.0) + 1)
    data = bag if bag.is_file() else next(p for p in bag.iterdir() if p.suffix != ".yaml")
    blob = data.read_bytes()
    data.write_bytes(blob[: len(blob) // 2])
    with pytest.raises(BagError, match=rf"{data.name if bag.is_file() else bag.name}.*truncated"):
        list(read_bag_maps(bag))


def test_not_a_bag(tmp_path):
    with pytest.raises(BagError, match="no such file"):
        read_last_map(tmp_path / "missing.bag")
    (tmp_path / "empty.mcap").write_bytes(b"")
    with pytest.raises(BagError, match="empty.mcap"):
        read_last_map(tmp_path / "empty.mcap")
    with pytest.raises(BagError, match="no metadata.yaml"):
        read_last_map(tmp_path)


def test_missing_topic_lists_topics_and_wrong_type(tmp_path):
    bag = bag_path(tmp_path, "ros1")
    with BagWriter(bag, "ros1") as w:
        w.write("/grid", GRID, w.grid(1.0, room_grid()))
        w.write("/pose", "geometry_msgs/msg/PoseStamped", _pose_stamped(w, 1.0, (0, 0, 0)))
    with pytest.raises(BagError, match=r"no topic /map; topics in the bag: /grid \(nav_msgs"):
        read_last_map(bag)
    with pytest.raises(BagError, match=r"/pose carries geometry_msgs/msg/PoseStamped"):
        read_last_map(bag, "/pose")
    assert read_last_map(bag, "/grid").shape == room_grid().shape


# ----------------------------------------------------------------------------- poses


def _yaw_q(yaw):
    return (math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2))


def _pose_stamped(w, t, xyz, yaw=0.0, frame="map"):
    return w.T["geometry_msgs/msg/PoseStamped"](header=w.header(t, frame),
                                                pose=w.pose(xyz, _yaw_q(yaw)))


def _cov_pose(w, t, xyz, yaw=0.0):
    T = w.T
    pwc = T["geometry_msgs/msg/PoseWithCovariance"](pose=w.pose(xyz, _yaw_q(yaw)),
                                                    covariance=np.zeros(36))
    return T["geometry_msgs/msg/PoseWithCovarianceStamped"](header=w.header(t), pose=pwc)


def _odom(w, t, xyz, yaw=0.0):
    T = w.T
    pwc = T["geometry_msgs/msg/PoseWithCovariance"](pose=w.pose(xyz, _yaw_q(yaw)),
                                                    covariance=np.zeros(36))
    twist = T["geometry_msgs/msg/TwistWithCovariance"](
        twist=T["geometry_msgs/msg/Twist"](linear=T["geometry_msgs/msg/Vector3"](x=0, y=0, z=0),
                                           angular=T["geometry_msgs/msg/Vector3"](x=0, y=0, z=0)),
        covariance=np.zeros(36))
    return T["nav_msgs/msg/Odometry"](header=w.header(t, "odom"), child_frame_id="base_link",
                                      pose=pwc, twist=twist)


def _tf(w, t, parent, child, xyz, yaw=0.0):
    T = w.T
    tr = T["geometry_msgs/msg/Transform"](
        translation=T["geometry_msgs/msg/Vector3"](x=xyz[0], y=xyz[1], z=xyz[2]),
        rotation=w.quat(_yaw_q(yaw)))
    return T["geometry_msgs/msg/TransformStamped"](header=w.header(t, parent),
                                                   child_frame_id=child, transform=tr)


def _path_msg(w, t, poses):
    return w.T["nav_msgs/msg/Path"](header=w.header(t),
                                    poses=[_pose_stamped(w, pt, p, yaw) for pt, p, yaw in poses])


POSES = [(1.0 + 0.1 * i, (0.5 * i, -0.25 * i, 0.0), 0.2 * i) for i in range(6)]


def _check(traj, poses=POSES):
    assert len(traj.timestamps) == len(poses)
    np.testing.assert_allclose(traj.timestamps, [p[0] for p in poses], atol=1e-9)
    np.testing.assert_allclose(traj.positions, [p[1] for p in poses], atol=1e-12)
    np.testing.assert_allclose(traj.orientations, [_yaw_q(p[2]) for p in poses], atol=1e-12)


@pytest.mark.parametrize("fmt", FORMATS)
def test_pose_topics(tmp_path, fmt):
    bag = bag_path(tmp_path, fmt)
    with BagWriter(bag, fmt) as w:
        for t, xyz, yaw in POSES:
            w.write("/slam_pose", "geometry_msgs/msg/PoseStamped", _pose_stamped(w, t, xyz, yaw))
            w.write("/amcl_pose", "geometry_msgs/msg/PoseWithCovarianceStamped",
                    _cov_pose(w, t, xyz, yaw))
            w.write("/odom", "nav_msgs/msg/Odometry", _odom(w, t, xyz, yaw))
            w.write("/gt", "geometry_msgs/msg/TransformStamped",
                    _tf(w, t, "world", "robot", xyz, yaw))
        w.write("/trajectory", "nav_msgs/msg/Path", _path_msg(w, 0.5, POSES[:2]))
        w.write("/trajectory", "nav_msgs/msg/Path", _path_msg(w, 2.0, POSES))
    for topic in ("/slam_pose", "/amcl_pose", "/odom", "/gt", "/trajectory"):
        traj = read_bag_trajectory(bag, topic)
        _check(traj)
        assert topic in traj.source
    with pytest.raises(BagError, match="several pose topics"):
        read_bag_trajectory(bag)
    with pytest.raises(BagError, match=r"no topic /nope; topics in the bag: /amcl_pose"):
        read_bag_trajectory(bag, "/nope")


def test_bad_quaternions_and_positions_in_a_bag_name_the_bag_and_pose(tmp_path):
    bag = bag_path(tmp_path, "mcap")
    with BagWriter(bag, "mcap") as w:
        for i, (t, xyz, _) in enumerate(POSES):
            q = (0.0, 0.0, 0.0, 0.0) if i == 2 else (2.0, 0.0, 0.0, 0.0)  # zero / not unit
            msg = w.T["geometry_msgs/msg/PoseStamped"](header=w.header(t), pose=w.pose(xyz, q))
            w.write("/zero", "geometry_msgs/msg/PoseStamped", msg)
            nan = (math.nan, 0.0, 0.0) if i == 3 else xyz
            w.write("/nan", "geometry_msgs/msg/PoseStamped", _pose_stamped(w, t, nan))
            w.write("/long", "geometry_msgs/msg/PoseStamped",
                    w.T["geometry_msgs/msg/PoseStamped"](header=w.header(t),
                                                         pose=w.pose(xyz, (2.0, 0, 0, 0))))
    with pytest.raises(slamq.TrajectoryError,
                       match=rf"{bag.name}:/zero: zero quaternion in pose 3"):
        read_bag_trajectory(bag, "/zero")
    with pytest.raises(slamq.TrajectoryError, match=rf"{bag.name}:/nan: NaN or infinite position "
                       r"in pose 4"):
        read_bag_trajectory(bag, "/nan")
    np.testing.assert_array_equal(read_bag_trajectory(bag, "/long").orientations[:, 0], 1.0)


def test_only_pose_topic_is_the_default(tmp_path):
    bag = bag_path(tmp_path, "ros1")
    with BagWriter(bag, "ros1") as w:
        w.write("/map", GRID, w.grid(0.5, room_grid()))
        for t, xyz, yaw in POSES:
            w.write("/odom", "nav_msgs/msg/Odometry", _odom(w, t, xyz, yaw))
    _check(read_bag_trajectory(bag))
    with pytest.raises(BagError, match=r"/map carries nav_msgs/msg/OccupancyGrid"):
        read_bag_trajectory(bag, "/map")


@pytest.mark.parametrize("fmt", ["ros1", "mcap"])
def test_tf_pair_and_chain(tmp_path, fmt):
    bag = bag_path(tmp_path, fmt)
    tfm = "tf2_msgs/msg/TFMessage"
    with BagWriter(bag, fmt) as w:
        # static base_link -> laser, 1 m ahead
        w.write("/tf_static", tfm, w.T[tfm](transforms=[
            _tf(w, 0.0, "base_link", "laser", (1.0, 0.0, 0.0))]), t=0.5)
        for t, xyz, yaw in POSES:
            # map -> odom: a constant 90 degree turn plus (10, 0)
            w.write("/tf", tfm, w.T[tfm](transforms=[
                _tf(w, t, "map", "odom", (10.0, 0.0, 0.0), math.pi / 2),
                _tf(w, t, "/odom", "base_link", xyz, yaw)]))
    _check(read_bag_trajectory(bag, "/tf", parent_frame="odom", child_frame="base_link"))
    _check(read_bag_trajectory(bag, "/tf:odom->base_link"))
    chain = read_bag_trajectory(bag, "/tf", parent_frame="map", child_frame="laser")
    assert len(chain.timestamps) == len(POSES)
    for (_t, (x, y, _), yaw), p, q in zip(POSES, chain.positions, chain.orientations):
        # laser in odom: (x, y) + R(yaw) (1, 0); then map: (10, 0) + R(90deg) * that
        lx, ly = x + math.cos(yaw), y + math.sin(yaw)
        np.testing.assert_allclose(p, (10.0 - ly, lx, 0.0), atol=1e-12)
        np.testing.assert_allclose(q, _yaw_q(yaw + math.pi / 2), atol=1e-12)
    with pytest.raises(BagError, match=r"2 moving frame pairs.*map->odom, odom->base_link"):
        read_bag_trajectory(bag, "/tf")
    with pytest.raises(BagError, match=r"no tf chain from map to camera"):
        read_bag_trajectory(bag, "/tf", parent_frame="map", child_frame="camera")


@pytest.mark.parametrize("fmt", FORMATS)
def test_pose_topics_equal_evo(tmp_path, fmt):
    """Same stamps and poses as evo's bag reader (which also uses rosbags) on every type."""
    pytest.importorskip("evo")
    from evo.tools import file_interface
    from rosbags.rosbag1 import Reader as Reader1
    from rosbags.rosbag2 import Reader as Reader2

    rng = np.random.default_rng(3)
    poses = [(5.0 + 0.01 * i + rng.uniform(0, 1e-3), tuple(rng.normal(size=3)),
              float(rng.uniform(-3, 3))) for i in range(50)]
    bag = bag_path(tmp_path, fmt)
    with BagWriter(bag, fmt) as w:
        for t, xyz, yaw in poses:
            w.write("/a", "geometry_msgs/msg/PoseStamped", _pose_stamped(w, t, xyz, yaw))
            w.write("/b", "geometry_msgs/msg/PoseWithCovarianceStamped", _cov_pose(w, t, xyz, yaw))
            w.write("/c", "nav_msgs/msg/Odometry", _odom(w, t, xyz, yaw))
            w.write("/d", "geometry_msgs/msg/TransformStamped", _tf(w, t, "w", "r", xyz, yaw))
            w.write("/e", "geometry_msgs/msg/PointStamped", w.T["geometry_msgs/msg/PointStamped"](
                header=w.header(t), point=w.T["geometry_msgs/msg/Point"](
                    x=xyz[0], y=xyz[1], z=xyz[2])))
    for topic in ("/a", "/b", "/c", "/d", "/e"):
        with (Reader1 if fmt == "ros1" else Reader2)(bag) as reader:
            ref = file_interface.read_bag_trajectory(reader, topic)
        got = read_bag_trajectory(bag, topic)
        np.testing.assert_array_equal(got.timestamps, ref.timestamps)
        np.testing.assert_array_equal(got.positions, ref.positions_xyz)
        np.testing.assert_allclose(got.orientations, ref.orientations_quat_wxyz, atol=1e-15)


def test_evo_style_tf_id(tmp_path):
    bag = bag_path(tmp_path, "ros1")
    tfm = "tf2_msgs/msg/TFMessage"
    with BagWriter(bag, "ros1") as w:
        for t, xyz, yaw in POSES:
            w.write("/tf", tfm, w.T[tfm](transforms=[_tf(w, t, "odom", "base_link", xyz, yaw)]))
    _check(read_bag_trajectory(bag, "/tf:odom.base_link"))
    _check(read_bag_trajectory(bag))  # the only moving pair


@pytest.mark.parametrize("fmt", FORMATS)
def test_an_undecodable_map_message_is_named_in_one_short_line(tmp_path, fmt):
    # a decoder's own message can quote the whole raw message; slamq's never does
    bag = bag_path(tmp_path, fmt)
    with BagWriter(bag, fmt) as w:
        w.write("/map", "nav_msgs/msg/OccupancyGrid", w.grid(1.0, room_grid()))
        conn = w.conns["/map"]
        w.writer.write(conn, int(2e9), bytes(range(256)) * 400)  # 100 KB of garbage
    with pytest.raises(BagError) as info:
        slamq.load_map(bag)
    text = str(info.value)
    assert "message 1" in text and str(bag.name) in text
    assert len(text) < 600 and "\n" not in text, text[:300]
