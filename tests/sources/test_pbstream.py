"""Cartographer .pbstream: a stream built here with a small protobuf encoder, read back."""

from __future__ import annotations

import struct

import numpy as np
import pytest
from _pbencode import (  # the encoder, shared with the map and fuzz tests
    NODES0,
    NODES1,
    encoded_nodes,
    f_msg,
    f_varint,
    full_stream,
    node,
    pose_graph,
    rigid3d,
    stream,
    trajectory,
    unix_ticks,
    yaw_xyzw,
)
from hypothesis import given, settings
from hypothesis import strategies as st

from slamq import TrajectoryError
from slamq.sources.pbstream import (
    PBSTREAM_MAGIC,
    UTS_EPOCH_OFFSET_TICKS,
    read_pbstream_poses,
    read_pbstream_trajectories,
    read_pbstream_trajectory,
)


def write(tmp_path, data: bytes, name="map.pbstream"):
    p = tmp_path / name
    p.write_bytes(data)
    return p


def check(traj, spec):
    np.testing.assert_array_equal(
        traj.timestamps, [(unix_ticks(s) - UTS_EPOCH_OFFSET_TICKS) / 1e7 for _, s, _, _ in spec]
    )
    np.testing.assert_allclose(traj.timestamps, [s for _, s, _, _ in spec], rtol=0, atol=1e-6)
    np.testing.assert_array_equal(traj.positions, [t for _, _, t, _ in spec])
    wxyz = [(q[3], q[0], q[1], q[2]) for _, _, _, q in spec]
    np.testing.assert_allclose(traj.orientations, wxyz, rtol=0, atol=1e-15)


@pytest.mark.parametrize("version", [1, 2])
def test_read_back_exact_poses(tmp_path, version):
    p = write(tmp_path, full_stream(version))
    check(read_pbstream_trajectory(p), NODES0)
    check(read_pbstream_trajectory(p, 1), NODES1)
    trajs = read_pbstream_trajectories(p)
    assert sorted(trajs) == [0, 1]
    assert "trajectory1" in trajs[1].source
    raw = read_pbstream_poses(p)
    assert raw[0][0].tolist() == [0, 1, 2, 5]  # node_index, zero left off the wire
    assert raw[0][1].tolist() == [unix_ticks(s) for _, s, _, _ in NODES0]


def test_load_trajectory_and_cli_read_pbstreams(tmp_path, capsys):
    from slamq.cli import main
    from slamq.metrics.ate import ate
    from slamq.sources.trajectories import load_trajectory

    p = write(tmp_path, full_stream())
    check(load_trajectory(p), NODES0)
    check(load_trajectory(p, topic="1"), NODES1)
    with pytest.raises(TrajectoryError, match="topic is a trajectory id"):
        load_trajectory(p, topic="/tf")
    gt = load_trajectory(p).write_tum(tmp_path / "gt.txt")
    assert main(["ate", str(gt), str(p), "-a", "none"]) == 0
    assert f"{ate(load_trajectory(gt), load_trajectory(p), align='none').rmse:.6f}" == "0.000000"
    assert "map.pbstream#trajectory0" in capsys.readouterr().out


def test_legacy_stream_without_header(tmp_path):
    # pre-header streams start with the PoseGraph; proto2 trajectories carry no id
    graph = pose_graph([trajectory(0, encoded_nodes(NODES1)), trajectory(0, encoded_nodes(NODES0))])
    p = write(tmp_path, stream(graph))
    check(read_pbstream_trajectory(p, 1), NODES0)
    check(read_pbstream_trajectory(p, 0), NODES1)


def test_nodes_out_of_time_order_are_sorted(tmp_path):
    spec = [NODES0[2], NODES0[0], NODES0[1]]
    graph = pose_graph([trajectory(0, encoded_nodes(spec))])
    p = write(tmp_path, stream(f_varint(1, 2), f_msg(1, graph)))
    check(read_pbstream_trajectory(p), NODES0[:3])


def test_errors_name_the_file_and_reason(tmp_path):
    with pytest.raises(TrajectoryError, match=r"missing.pbstream: no such file"):
        read_pbstream_trajectory(tmp_path / "missing.pbstream")
    bad = write(tmp_path, b"\x00" * 32, "bad.pbstream")
    with pytest.raises(TrajectoryError, match=r"bad.pbstream: not a Cartographer pbstream"):
        read_pbstream_trajectory(bad)
    full = full_stream()
    # cut inside the PoseGraph record
    cut = write(tmp_path, full[:60], "cut.pbstream")
    with pytest.raises(TrajectoryError, match=r"cut.pbstream: truncated pbstream"):
        read_pbstream_trajectory(cut)
    with pytest.raises(TrajectoryError, match=r"no trajectory 7 \(trajectories: 0, 1\)"):
        read_pbstream_trajectory(write(tmp_path, full), 7)
    garbage = struct.pack("<Q", PBSTREAM_MAGIC) + struct.pack("<Q", 5) + b"abcde"
    with pytest.raises(TrajectoryError, match=r"corrupt pbstream record \(gzip"):
        read_pbstream_trajectory(write(tmp_path, garbage, "garbage.pbstream"))
    broken = stream(f_varint(1, 2), f_msg(1, b"\x22\x7f\x01"))  # length runs past the end
    with pytest.raises(TrajectoryError, match=r"corrupt pbstream \(truncated length"):
        read_pbstream_trajectory(write(tmp_path, broken, "broken.pbstream"))
    for size in (1 << 40, (1 << 64) - 1):  # a corrupt record size: no huge allocation
        huge = struct.pack("<Q", PBSTREAM_MAGIC) + struct.pack("<Q", size) + b"abc"
        with pytest.raises(TrajectoryError, match=rf"huge.pbstream: truncated pbstream "
                           rf"\(record of {size} bytes, 3 left\)"):
            read_pbstream_trajectory(write(tmp_path, huge, "huge.pbstream"))
    with pytest.raises(TrajectoryError, match=r"format_version 9"):
        read_pbstream_trajectory(write(tmp_path, stream(f_varint(1, 9)), "v9.pbstream"))
    empty_traj = stream(f_varint(1, 2), f_msg(1, pose_graph([trajectory(0, [])])))
    with pytest.raises(TrajectoryError, match=r"trajectory 0 has no nodes"):
        read_pbstream_trajectory(write(tmp_path, empty_traj, "empty.pbstream"))


def test_protobuf_library_agrees_if_installed(tmp_path):
    """Cross-check the hand decoder's field reading with google.protobuf's wire parser."""
    pytest.importorskip("google.protobuf")
    from google.protobuf import descriptor_pb2, descriptor_pool, message_factory

    fdp = descriptor_pb2.FileDescriptorProto(name="t.proto", package="t", syntax="proto3")
    vec = fdp.message_type.add(name="Vector3d")
    for i, n in enumerate("xyz"):
        vec.field.add(name=n, number=i + 1, type=1, label=1)  # TYPE_DOUBLE
    quat = fdp.message_type.add(name="Quaterniond")
    for i, n in enumerate("xyzw"):
        quat.field.add(name=n, number=i + 1, type=1, label=1)
    rig = fdp.message_type.add(name="Rigid3d")
    rig.field.add(name="translation", number=1, type=11, label=1, type_name=".t.Vector3d")
    rig.field.add(name="rotation", number=2, type=11, label=1, type_name=".t.Quaterniond")
    nd = fdp.message_type.add(name="Node")
    nd.field.add(name="node_index", number=7, type=5, label=1)  # int32
    nd.field.add(name="timestamp", number=1, type=3, label=1)  # int64
    nd.field.add(name="pose", number=5, type=11, label=1, type_name=".t.Rigid3d")
    pool = descriptor_pool.DescriptorPool()
    pool.Add(fdp)
    Node = message_factory.GetMessageClass(pool.FindMessageTypeByName("t.Node"))
    msgs = [Node.FromString(b) for b in encoded_nodes(NODES0)]
    p = write(tmp_path, full_stream())
    idx, ticks, pos, rot = read_pbstream_poses(p)[0]
    assert [m.node_index for m in msgs] == idx.tolist()
    assert [m.timestamp for m in msgs] == ticks.tolist()
    assert [[m.pose.translation.x, m.pose.translation.y, m.pose.translation.z]
            for m in msgs] == pos.tolist()


finite = st.floats(allow_nan=False, allow_infinity=False, width=64)


@settings(max_examples=40, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.integers(0, 2**31 - 1),  # node_index
            st.integers(-(2**63), 2**63 - 1),  # universal ticks, any int64
            st.tuples(finite, finite, finite),
            st.tuples(finite, finite, finite, finite),
        ),
        min_size=1,
        max_size=8,
    ),
    st.integers(-(2**31), 2**31 - 1),
)
def test_wire_round_trip_is_exact(tmp_path_factory, nodes, tid):
    """Any node list (negative ints, zeros left off, any doubles) decodes to what was encoded."""
    encoded = [f_msg(5, rigid3d(t, q)) + f_varint(1, ticks) + f_varint(7, index)
               for index, ticks, t, q in nodes]
    graph = pose_graph([trajectory(tid, encoded)])
    p = write(tmp_path_factory.mktemp("pb"), stream(f_varint(1, 2), f_msg(1, graph)))
    (key,) = read_pbstream_poses(p)
    assert key == tid
    idx, ticks, pos, rot = read_pbstream_poses(p)[tid]
    assert idx.tolist() == [n[0] for n in nodes]
    assert ticks.tolist() == [n[1] for n in nodes]
    assert pos.tolist() == [list(n[2]) for n in nodes]
    assert rot.tolist() == [[n[3][3], n[3][0], n[3][1], n[3][2]] for n in nodes]


@pytest.mark.parametrize("ticks", [-(2**63), -1, 2**63 - 1])
def test_node_times_outside_universal_time_are_refused(tmp_path, ticks):
    """A tick count near INT64_MIN used to wrap to a plausible positive Unix time."""
    nodes = [node(0, unix_ticks(1.0), (0, 0, 0), yaw_xyzw(0.0)),
             node(1, ticks % 2**64, (1, 0, 0), yaw_xyzw(0.0))]  # varints are unsigned
    p = write(tmp_path, stream(f_varint(1, 2), f_msg(1, pose_graph([trajectory(0, nodes)]))))
    with pytest.raises(TrajectoryError, match="map.pbstream: trajectory 0: node time .* is "
                                              "not a universal time"):
        read_pbstream_trajectory(p)


@pytest.mark.parametrize("version", [2, "legacy"])
def test_a_trajectory_walked_as_a_stream_reads_as_one_kept_whole(tmp_path, version,
                                                                  monkeypatch):
    # trajectories up to 16 MiB are parsed in memory, longer ones field by field as they
    # stream by: both give the same poses (the cap set to 0 forces the stream here)
    from slamq.sources import pbstream

    graph = pose_graph([trajectory(0, encoded_nodes(NODES0)),
                        trajectory(1, encoded_nodes(NODES1))])
    data = stream(graph) if version == "legacy" else full_stream(version)
    p = write(tmp_path, data)
    whole = pbstream.read_pbstream_poses(p)
    monkeypatch.setattr(pbstream, "_TRAJECTORY", (0, pbstream._TRAJECTORY[1]))
    walked = pbstream.read_pbstream_poses(p)
    assert sorted(walked) == sorted(whole) == [0, 1]
    for k in whole:
        for a, b in zip(whole[k], walked[k]):
            assert np.array_equal(a, b)
    check(read_pbstream_trajectory(p), NODES0)
