"""The writers of ground truth on demand, read back: the MRPT rawlog by MRPT's own
rawlog-edit (skipped without mrpt-apps), the CARMEN log by its parser and carmen2rawlog,
every ROS bag by rosbags and by slamq's bag readers. Tiny sequences from tests/synth/_world.py
(an exact ray cast in a small walled world)."""

from __future__ import annotations

import math
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from _world import compose, make_sequence

from slamq.errors import SlamqError
from slamq.synth.writers import (
    EPOCH,
    FORMATS,
    graphslam_nodes,
    mrpt_timestamp,
    odometry_increments,
    read_carmen,
    write,
    write_carmen,
    write_groundtruth,
    write_rawlog,
)

HAS_MRPT = shutil.which("rawlog-edit") is not None
needs_mrpt = pytest.mark.skipif(not HAS_MRPT,
                                reason="rawlog-edit absent (apt-get install mrpt-apps)")


@pytest.fixture(scope="module")
def seq():
    """40 scans x 61 beams, noisy odometry, a laser 0.1 m ahead turned 0.05 rad, and a few
    beams without a return."""
    s = make_sequence(40, 61, odom_noise=0.05, seed=3, offset=(0.1, 0.02, 0.05), name="tiny")
    s.ranges[:, :3] = np.inf
    s.ranges[5, 30] = np.inf
    return s


def _mrpt(*args: str, cwd: Path) -> str:
    proc = subprocess.run(["rawlog-edit", *args], cwd=cwd, capture_output=True, text=True,
                          stdin=subprocess.DEVNULL, timeout=60)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return proc.stdout + proc.stderr


# ---------------------------------------------------------------------------- the API

def test_write_every_format(tmp_path, seq):
    out = write(seq, tmp_path)
    assert set(out) == set(FORMATS) == {"rawlog", "carmen", "rosbag1", "rosbag2", "mcap"}
    assert out["rawlog"] == tmp_path / "tiny.rawlog" and out["carmen"] == tmp_path / "tiny.log"
    assert out["rosbag1"].suffix == ".bag"
    assert (out["rosbag2"] / "metadata.yaml").is_file() and list(out["rosbag2"].glob("*.db3"))
    assert (out["mcap"] / "metadata.yaml").is_file() and list(out["mcap"].glob("*.mcap"))
    assert (tmp_path / "tiny.rawlog.steps.txt").is_file()
    assert (tmp_path / "tiny.rawlog.nodes.txt").is_file()
    # written again: replaced, not refused
    assert write(seq, tmp_path, "mcap")["mcap"] == out["mcap"]


def test_unknown_format_is_refused(tmp_path, seq):
    with pytest.raises(SlamqError, match="unknown format.*'gif'.*known: rawlog"):
        write(seq, tmp_path, ["rawlog", "gif"])
    with pytest.raises(SlamqError, match="motion_model: unknown keys"):
        write_rawlog(seq, tmp_path / "x.rawlog", motion_model={"a9": 1})


def test_unwritable_folder_names_the_file(tmp_path, seq):
    (tmp_path / "f").write_text("a file, not a folder")
    with pytest.raises(SlamqError, match=r"f/s\.rawlog: cannot write"):
        write_rawlog(seq, tmp_path / "f" / "s.rawlog")
    with pytest.raises(SlamqError, match=r"f/s\.log: cannot write"):
        write_carmen(seq, tmp_path / "f" / "s.log")


def test_odometry_increments_compose_back_to_the_odometry(seq):
    inc = odometry_increments(seq.odom)
    assert np.all(inc[0] == 0)
    pose = seq.odom[0].copy()
    for i in range(1, len(seq)):
        pose = compose(pose, inc[i])
    np.testing.assert_allclose(pose, seq.odom[-1], atol=1e-9)


def test_mrpt_timestamps():
    # 100 ns ticks since 1601-01-01: the Unix epoch is 11644473600 s after it
    assert mrpt_timestamp(0.0) == 11_644_473_600 * 10_000_000
    assert mrpt_timestamp(EPOCH + 0.5) - mrpt_timestamp(EPOCH) == 5_000_000
    assert mrpt_timestamp(np.array([1.25, 2.0])).tolist() == [
        mrpt_timestamp(0.0) + 12_500_000, mrpt_timestamp(0.0) + 20_000_000]


def test_groundtruth_file(tmp_path, seq):
    import slamq

    p = write_groundtruth(seq, tmp_path / "gt.tum")
    t = slamq.load_trajectory(p)
    np.testing.assert_allclose(t.timestamps, EPOCH + seq.stamps)
    np.testing.assert_allclose(t.positions[:, :2], seq.gt[:, :2], atol=1e-6)
    np.testing.assert_allclose(t.yaw, seq.gt[:, 2], atol=1e-6)


def test_graphslam_nodes_follow_distance_and_angle():
    # 0.1 m steps, then a turn on the spot in 10 degree steps
    odom = np.array([[0.1 * i, 0, 0] for i in range(13)]
                    + [[1.2, 0, math.radians(10 * k)] for k in range(1, 10)])
    nodes = graphslam_nodes(odom, 0.5, math.radians(30))
    assert nodes.tolist() == [0, 6, 12, 16, 20]


# ---------------------------------------------------------------------------- MRPT rawlog

@needs_mrpt
def test_rawlog_edit_reads_the_rawlog(tmp_path, seq):
    p = write_rawlog(seq, tmp_path / "s.rawlog")
    info = _mrpt("--info", "-i", str(p), cwd=tmp_path)
    assert "Actions/SensoryFrame format       : Yes" in info
    assert f"Overall number of objects         : {2 * len(seq)}" in info
    assert "Earliest timestamp                : 1700000000.000000" in info
    assert f"Latest timestamp                  : {EPOCH + seq.stamps[-1]:.6f}" in info
    assert f"LASER /     {len(seq)} /10.000" in info


@needs_mrpt
def test_mrpt_reads_back_the_scans_and_the_sensor_pose(tmp_path, seq):
    p = write_rawlog(seq, tmp_path / "s.rawlog", sensor_label="FRONT")
    # rawlog-edit 2.5.8 writes <folder><stem>_<label>.txt (no separator): run it inside
    _mrpt("--export-2d-scans-txt", "-i", p.name, cwd=tmp_path)
    txt = tmp_path / "s_FRONT.txt"
    rows = np.loadtxt(txt, comments="%")
    n, b = seq.ranges.shape
    assert rows.shape == (n, 1 + 2 * b)
    np.testing.assert_allclose(rows[:, 0], EPOCH + seq.stamps, atol=1e-6)
    valid = rows[:, 1 + b:].astype(bool)
    np.testing.assert_array_equal(valid, np.isfinite(seq.ranges))
    np.testing.assert_allclose(rows[:, 1:1 + b][valid], seq.ranges[valid], atol=6e-4)
    np.testing.assert_allclose(rows[:, 1:1 + b][~valid], seq.laser.max_range)
    _mrpt("--list-poses", "--text-file-output", "poses.txt", "-i", str(p), cwd=tmp_path)
    first = (tmp_path / "poses.txt").read_text().splitlines()[0].strip("[] \n").split()
    x, y, z, yaw = (float(v) for v in first[:4])
    assert (x, y, z) == pytest.approx((0.1, 0.02, 0.0))
    assert yaw == pytest.approx(math.degrees(0.05), abs=1e-5)  # listed in degrees


# ---------------------------------------------------------------------------- CARMEN

def test_carmen_parsed_back(tmp_path, seq):
    p = write_carmen(seq, tmp_path / "s.log")
    log = read_carmen(p)
    n = len(seq)
    assert log["ranges"].shape == seq.ranges.shape
    fin = np.isfinite(seq.ranges)
    np.testing.assert_array_equal(np.isfinite(log["ranges"]), fin)
    np.testing.assert_allclose(log["ranges"][fin], seq.ranges[fin], atol=5.01e-4)
    np.testing.assert_allclose(log["stamps"], EPOCH + seq.stamps, atol=1e-6)
    np.testing.assert_allclose(log["odom"], seq.odom, atol=1e-6)
    np.testing.assert_allclose(log["odom_stamps"], log["stamps"])
    # both poses of a laser line are odometry: the robot's, and the laser at its offset
    np.testing.assert_allclose(log["robot_pose"], seq.odom, atol=1e-6)
    offset = np.broadcast_to(np.asarray(seq.laser.offset), (n, 3))
    np.testing.assert_allclose(log["laser_pose"], compose(seq.odom, offset), atol=2e-6)
    assert not np.allclose(log["robot_pose"], seq.gt, atol=1e-3)  # no ground truth leaked
    assert log["fov"] == pytest.approx(seq.laser.fov, abs=1e-6)
    assert float(log["params"]["robot_front_laser_max"]) == seq.laser.max_range


@pytest.mark.skipif(not shutil.which("carmen2rawlog"), reason="carmen2rawlog absent")
def test_carmen2rawlog_converts_the_log(tmp_path, seq):
    p = write_carmen(seq, tmp_path / "s.log")
    proc = subprocess.run(["carmen2rawlog", "-q", "-w", "-i", str(p), "-o",
                           str(tmp_path / "s.rawlog")], capture_output=True, text=True,
                          stdin=subprocess.DEVNULL, timeout=60, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-2000:]
    info = _mrpt("--info", "-i", str(tmp_path / "s.rawlog"), cwd=tmp_path)
    assert "Observations format               : Yes" in info
    assert f"ROBOTLASER1 /     {len(seq)}" in info and f"ODOMETRY /     {len(seq)}" in info
    # MRPT 2.5.8 reads the timestamp as microseconds(1e-6 * t): all collapse into one
    assert "/  inf /0.000" in info


# ---------------------------------------------------------------------------- ROS bags

BAGS = ("rosbag1", "rosbag2", "mcap")


@pytest.fixture(scope="module")
def bags(tmp_path_factory, seq):
    return write(seq, tmp_path_factory.mktemp("bags"), BAGS)


@pytest.mark.parametrize("fmt", BAGS)
def test_bag_read_back_by_rosbags(bags, seq, fmt):
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    n = len(seq)
    ns = np.round((EPOCH + seq.stamps) * 1e9).astype(np.int64)
    with AnyReader([bags[fmt]], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as r:
        topics = {c.topic: c.msgtype for c in r.connections}
        expected = {"/scan": "sensor_msgs/msg/LaserScan", "/odom": "nav_msgs/msg/Odometry",
                    "/tf": "tf2_msgs/msg/TFMessage", "/clock": "rosgraph_msgs/msg/Clock"}
        if fmt != "rosbag1":
            expected["/tf_static"] = "tf2_msgs/msg/TFMessage"
        assert topics == expected
        scans, odom, tf, static = [], [], [], []
        for conn, t, raw in r.messages():
            msg = r.deserialize(raw, conn.msgtype)
            if conn.topic == "/scan":
                stamp = msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec
                assert stamp == t and msg.header.frame_id == "laser"
                scans.append((t, msg))
            elif conn.topic == "/odom":
                assert (msg.header.frame_id, msg.child_frame_id) == ("odom", "base_link")
                odom.append(msg)
            elif conn.topic == "/tf":
                tf.append([(x.header.frame_id, x.child_frame_id) for x in msg.transforms])
            elif conn.topic == "/tf_static":
                static.append(msg.transforms)
        assert [t for t, _ in scans] == ns.tolist() and len(odom) == n
        got = np.array([m.ranges for _, m in scans])
        np.testing.assert_array_equal(got, seq.ranges)  # float32 exactly, inf kept
        m = scans[0][1]
        assert m.angle_min == pytest.approx(seq.laser.angle_min)
        assert m.angle_max == pytest.approx(-seq.laser.angle_min)
        assert m.angle_increment == pytest.approx(seq.laser.angle_increment)
        assert (m.range_min, m.range_max) == pytest.approx((seq.laser.min_range, 20.0))
        if fmt == "rosbag1":
            assert all(f == [("odom", "base_link"), ("base_link", "laser")] for f in tf)
        else:
            assert all(f == [("odom", "base_link")] for f in tf)
            assert len(static) == 1 and static[0][0].child_frame_id == "laser"
            assert static[0][0].transform.translation.y == pytest.approx(0.02)
        assert len(tf) == n


@pytest.mark.parametrize("fmt", BAGS)
def test_bag_read_back_by_slamq(bags, seq, fmt):
    from slamq.sources.bag_poses import read_bag_trajectory

    t = read_bag_trajectory(bags[fmt], "/odom")
    np.testing.assert_allclose(t.timestamps, EPOCH + seq.stamps, rtol=0, atol=1e-6)
    np.testing.assert_allclose(t.positions[:, :2], seq.odom[:, :2], atol=1e-9)
    np.testing.assert_allclose(np.angle(np.exp(1j * (t.yaw - seq.odom[:, 2]))), 0, atol=1e-9)
    # the laser through /tf (+ /tf_static): odometry composed with the laser's offset
    laser = read_bag_trajectory(bags[fmt], "/tf", parent_frame="odom", child_frame="laser")
    want = compose(seq.odom, np.broadcast_to(np.asarray(seq.laser.offset), seq.odom.shape))
    np.testing.assert_allclose(laser.positions[:, :2], want[:, :2], atol=1e-9)
    np.testing.assert_allclose(np.angle(np.exp(1j * (laser.yaw - want[:, 2]))), 0, atol=1e-9)
