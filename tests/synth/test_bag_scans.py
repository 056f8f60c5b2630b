"""Laser scans read back from ROS bags (slamq.sources.bag_scans) as a ``bag:`` sequence
of ``slamq run`` converts them: a tiny simulated drive written as ROS 1 / ROS 2 / MCAP
bags by slamq.synth.writers, and, when ../shared/data is beside the clone, the MIT CSAIL
bag against its original CARMEN log."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from _world import make_sequence

from slamq.errors import BagError
from slamq.sources.bag_scans import read_bag_scans
from slamq.synth.writers import EPOCH, write

BAGS = ("rosbag1", "rosbag2", "mcap")
DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "datasets2d"


@pytest.fixture(scope="module")
def seq():
    s = make_sequence(30, 41, odom_noise=0.05, seed=5, offset=(0.1, 0.02, 0.05), name="b")
    s.ranges[:, :2] = np.inf
    return s


@pytest.fixture(scope="module")
def bags(tmp_path_factory, seq):
    return write(seq, tmp_path_factory.mktemp("bags"), BAGS)


@pytest.mark.parametrize("fmt", BAGS)
def test_scans_come_back_with_their_stamps_odometry_and_laser_offset(bags, seq, fmt):
    scans = list(read_bag_scans(bags[fmt]))
    assert len(scans) == len(seq)
    np.testing.assert_allclose([s.stamp for s in scans], EPOCH + seq.stamps, rtol=0,
                               atol=1e-6)
    # each scan's odometry is the odometry message at its stamp
    odom = np.array([s.odom for s in scans])
    np.testing.assert_allclose(odom[:, :2], seq.odom[:, :2], atol=1e-9)
    np.testing.assert_allclose(np.angle(np.exp(1j * (odom[:, 2] - seq.odom[:, 2]))), 0,
                               atol=1e-9)
    np.testing.assert_array_equal(np.array([s.ranges for s in scans]), seq.ranges)
    s = scans[0]
    assert s.angle_min == pytest.approx(seq.laser.angle_min)
    assert s.angle_increment == pytest.approx(seq.laser.angle_increment)
    assert s.max_range == pytest.approx(20.0)
    # base_link -> laser from /tf (ROS 1) or /tf_static (ROS 2, MCAP)
    assert s.offset == pytest.approx(seq.laser.offset, abs=1e-9)
    assert [s.line for s in read_bag_scans(bags[fmt], max_scans=4)] == [1, 2, 3, 4]


def test_odometry_between_messages_is_interpolated(bags, seq):
    """Scans read against an odometry topic sampled at every other scan: the poses in
    between are interpolated in time (the heading on the shorter arc)."""
    from slamq.sources.bag_scans import _pose_at

    t = EPOCH + seq.stamps[::2]
    pose = seq.odom[::2]
    mid = 0.5 * (t[3] + t[4])
    x, y, yaw = _pose_at(t, pose, mid)
    assert (x, y) == pytest.approx(tuple(0.5 * (pose[3, :2] + pose[4, :2])))
    d = math.atan2(math.sin(pose[4, 2] - pose[3, 2]), math.cos(pose[4, 2] - pose[3, 2]))
    assert yaw == pytest.approx(math.atan2(math.sin(pose[3, 2] + d / 2),
                                           math.cos(pose[3, 2] + d / 2)))
    assert _pose_at(t, pose, t[0] - 5) == pytest.approx(tuple(pose[0]))
    assert _pose_at(t, pose, t[-1] + 5) == pytest.approx(tuple(pose[-1]))


def test_a_missing_topic_names_the_bag_and_its_topics(bags):
    with pytest.raises(BagError, match=r"no topic /laser; topics in the bag: .*/scan"):
        next(read_bag_scans(bags["rosbag1"], "/laser"))
    with pytest.raises(BagError, match=r"carries sensor_msgs/msg/LaserScan"):
        next(read_bag_scans(bags["rosbag1"], "/scan", "/scan"))


@pytest.mark.skipif(not (DATA / "mit-csail" / "mit-csail.orig.bag").exists(),
                    reason="../shared/data/datasets2d absent")
def test_the_mit_csail_bag_gives_the_scans_of_its_carmen_log():
    from slamq.sources.carmen import CarmenLog

    bag = list(read_bag_scans(DATA / "mit-csail" / "mit-csail.orig.bag", max_scans=400))
    log = list(CarmenLog(DATA / "mit-csail" / "mit-csail.clf").scans(max_scans=400))
    assert [s.stamp for s in bag] == [s.stamp for s in log]
    np.testing.assert_allclose([s.odom for s in bag], [s.odom for s in log], atol=1e-12)
    np.testing.assert_array_equal([s.ranges for s in bag], [s.ranges for s in log])
    assert bag[0].angle_increment == pytest.approx(log[0].angle_increment, rel=1e-7)


def test_a_bag_sequence_of_slamq_run_is_written_as_a_rawlog_on_its_clock(tmp_path, bags, seq):
    """``bag:`` in a run config: the bag's scans written as the rawlog the programs read,
    its steps sidecar on the bag's clock, node sidecars from its odometry; converted once."""
    import json

    from slamq.runner.config import load_config
    from slamq.runner.planning import prepare_inputs
    from slamq.synth.writers.rawlog import graphslam_nodes

    doc = {"base_dir": str(tmp_path), "output": "out",
           "sequences": {"drive": {"bag": str(bags["mcap"]), "max_scans": 25}},
           "algorithms": {"g": {"command": ["true"], "params": {"spacing": [0.3]},
                                "outputs": {"trajectory": {
                                    "path": "g.graph", "format": "mrpt",
                                    "times": "{input}.nodes-{param.spacing}m.txt"}}}}}
    prepare_inputs(load_config(doc))
    folder = tmp_path / "out" / "sequences" / "drive"
    steps = np.loadtxt(folder / "drive.rawlog.steps.txt")
    np.testing.assert_allclose(steps, EPOCH + seq.stamps[:25], rtol=0, atol=1e-6)
    want = steps[graphslam_nodes(seq.odom[:25], 0.3, math.radians(30.0))]
    np.testing.assert_allclose(np.loadtxt(folder / "drive.rawlog.nodes-0.3m.txt"), want,
                               rtol=0, atol=1e-6)
    info = json.loads((folder / "conversion.json").read_text())
    assert info["recipe"]["kind"] == "bag" and info["scans"] == 25
    before = (folder / "drive.rawlog").stat().st_mtime_ns
    prepare_inputs(load_config(doc))
    assert (folder / "drive.rawlog").stat().st_mtime_ns == before
    doc["sequences"]["drive"]["scan_topic"] = "/odom"
    with pytest.raises(BagError, match="carries nav_msgs/msg/Odometry"):
        prepare_inputs(load_config(doc))


def _rewrite(src: Path, dst: Path, edit) -> Path:
    """A copy of a ROS 1 bag, ``edit(topic, index, message)`` changing the messages of
    ``/tf`` and ``/scan`` in place (``index`` counts a topic's messages from 1)."""
    from rosbags.rosbag1 import Reader, Writer

    from slamq.synth.writers.ros import _typestore

    store = _typestore(True)
    seen: dict[str, int] = {}
    with Reader(src) as reader, Writer(dst) as writer:
        conns = {c.id: writer.add_connection(c.topic, c.msgtype, typestore=store)
                 for c in reader.connections}
        for conn, t, raw in reader.messages():
            if conn.topic in ("/tf", "/scan"):
                seen[conn.topic] = seen.get(conn.topic, 0) + 1
                msg = store.deserialize_ros1(raw, conn.msgtype)
                edit(conn.topic, seen[conn.topic], msg)
                raw = store.serialize_ros1(msg, conn.msgtype)
            writer.write(conns[conn.id], t, raw)
    return dst


def _flip_laser_tf(topic: str, _index: int, msg) -> None:
    """``base_link -> laser`` written the other way round (the inverse transform)."""
    for tf in msg.transforms if topic == "/tf" else ():
        if tf.child_frame_id != "laser":
            continue
        tr, q = tf.transform.translation, tf.transform.rotation
        yaw = 2 * math.atan2(q.z, q.w)
        c, s = math.cos(yaw), math.sin(yaw)
        tr.x, tr.y = -(c * tr.x + s * tr.y), s * tr.x - c * tr.y
        q.z = -q.z
        tf.header.frame_id, tf.child_frame_id = "laser", "base_link"


def test_both_bag_readers_take_the_laser_offset_given_either_way_round(bags, seq, tmp_path):
    """``slamq.load_scans`` and ``bag:`` sequences read a bag's scans through one walk: a
    ``laser -> base_link`` transform is the inverse of the offset for both (load_scans
    used to ignore it and take a zero offset)."""
    from slamq.sources.scans import load_scans

    flipped = _rewrite(bags["rosbag1"], tmp_path / "flipped.bag", _flip_laser_tf)
    assert next(read_bag_scans(flipped)).offset == pytest.approx(seq.laser.offset, abs=1e-9)
    assert load_scans(flipped).offset == pytest.approx(seq.laser.offset, abs=1e-9)


def test_a_reading_at_range_min_is_no_return_in_both_readers(seq, tmp_path):
    """docs/spec.md 7b: a beam is valid when range_min < r < range_max (read_bag_scans
    used to keep r == range_min)."""
    import dataclasses

    from slamq.sources.scans import load_scans

    lo = np.float32(seq.laser.min_range)
    ranges = seq.ranges.copy()
    ranges[:, 2] = lo
    ranges[:, 3] = np.nextafter(lo, np.float32(1))
    bag = write(dataclasses.replace(seq, ranges=ranges), tmp_path, ("rosbag1",))["rosbag1"]
    for got in (np.array([s.ranges for s in read_bag_scans(bag)]), load_scans(bag).ranges):
        assert np.isinf(got[:, 2]).all()
        assert (got[:, 3] == ranges[:, 3]).all()
        np.testing.assert_array_equal(got[:, 4:], ranges[:, 4:])


def test_load_scans_refuses_a_bag_whose_scans_change_frame(bags, tmp_path):
    """Scans from two frames (two lasers on one topic) have two offsets: refused, naming
    the message, as a CARMEN log's would be (load_scans used to take the first frame's)."""
    from slamq.errors import SequenceError
    from slamq.sources.scans import load_scans

    def fifth_in_base_link(topic: str, index: int, msg) -> None:
        if topic == "/scan" and index == 5:
            msg.header.frame_id = "base_link"  # no offset in the robot's frame

    out = _rewrite(bags["rosbag1"], tmp_path / "two-frames.bag", fifth_in_base_link)
    with pytest.raises(SequenceError, match=r"two-frames.bag \(/scan, message 5\): the scans "
                                            "change their laser offset on the robot"):
        load_scans(out)
    assert [s.offset == (0.0, 0.0, 0.0) for s in read_bag_scans(out)].count(True) == 1
