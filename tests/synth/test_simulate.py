"""simulate, odometry and the ground-truth files: determinism, the harness telling the
truth (exact odometry without noise, scans that land on the walls), files that load back."""

from __future__ import annotations

import json
import math
from pathlib import Path

import cv2
import numpy as np
import pytest

import slamq
from slamq.errors import SlamqError
from slamq.models import Trajectory
from slamq.synth import (
    NOISE,
    LaserSpec,
    OdometryNoise,
    load_sequence,
    save_sequence,
    simulate,
    visible_map,
    world,
    write_truth,
)
from slamq.synth.sensors import odometry

LASER = LaserSpec(beams=271)


@pytest.fixture(scope="module")
def office() -> slamq.OccupancyMap:
    return world(4, kind="office", size=(10.0, 8.0))


def _traj(seq: slamq.synth.Recording, poses: np.ndarray) -> Trajectory:
    return Trajectory.from_xy_yaw(seq.stamps, poses[:, 0], poses[:, 1], poses[:, 2])


def test_the_same_seed_gives_the_same_sequence(office) -> None:
    a = simulate(office, seed=2, laser=LASER, length=15.0)
    b = simulate(office, seed=2, laser=LASER, length=15.0, threads=1)
    for f in ("stamps", "gt", "odom", "ranges"):
        assert np.array_equal(getattr(a, f), getattr(b, f)), f
    c = simulate(office, seed=3, laser=LASER, length=15.0)
    assert not np.array_equal(a.ranges, c.ranges[:len(a.ranges)]) or len(a) != len(c)
    assert a.meta == b.meta
    json.dumps(a.meta)


def test_without_noise_the_odometry_is_the_ground_truth(office) -> None:
    seq = simulate(office, seed=1, noise="none", laser=LASER, kidnaps=0)
    err = slamq.ate(_traj(seq, seq.gt), _traj(seq, seq.odom), align="none")
    assert err.max < 1e-9
    assert slamq.ate(_traj(seq, seq.gt), _traj(seq, seq.odom)).rmse < 1e-9


def test_scans_land_on_the_walls(office) -> None:
    seq = simulate(office, seed=1, noise="high", laser=LaserSpec(beams=541, range_noise=0.01))
    w = seq.world
    r = seq.ranges.astype(np.float64)
    ok = np.isfinite(r)
    assert ok.mean() > 0.9
    a = seq.gt[:, 2:3] + seq.laser.angles()[None, :]
    x = (seq.gt[:, 0:1] + r * np.cos(a))[ok]
    y = (seq.gt[:, 1:2] + r * np.sin(a))[ok]
    col = np.floor((x - w.origin[0]) / w.resolution).astype(int)
    row = w.shape[0] - 1 - np.floor((y - w.origin[1]) / w.resolution).astype(int)
    walls = ((w.values < 128) & ~w.unknown).astype(np.uint8)
    near = cv2.dilate(walls, np.ones((3, 3), np.uint8)) > 0
    assert near[row, col].mean() >= 0.99


def test_odometry_noise_grows_with_the_level(office) -> None:
    seq = simulate(office, seed=0, noise="none", laser=LaserSpec(beams=3))
    gt = _traj(seq, seq.gt)
    errs = {}
    for level in ("low", "high"):
        odom = odometry(seq.gt, level, seed=5)
        errs[level] = slamq.ate(gt, _traj(seq, odom), align="origin").rmse
    assert 0 < errs["low"] < errs["high"]
    # scale error alone: the path reads longer by that share
    longer = odometry(seq.gt, OdometryNoise(scale=0.1), seed=0)
    d_gt = np.hypot(*np.diff(seq.gt[:, :2], axis=0).T).sum()
    d_od = np.hypot(*np.diff(longer[:, :2], axis=0).T).sum()
    assert d_od / d_gt == pytest.approx(1.1, rel=1e-6)
    # heading bias alone turns the odometry counter-clockwise by bias * distance
    biased = odometry(seq.gt, OdometryNoise(heading_bias=0.01), seed=0)
    turned = np.unwrap(biased[:, 2]) - np.unwrap(seq.gt[:, 2])
    assert turned[-1] == pytest.approx(0.01 * d_gt, rel=1e-6)
    assert NOISE["high"].scale == 0.02 and NOISE["low"].translation == 0.01


def test_kidnaps_are_invisible_to_the_odometry(office) -> None:
    seq = simulate(office, seed=2, noise="none", laser=LaserSpec(beams=3), kidnaps=1)
    (k,) = seq.meta["drive"]["kidnaps"]
    assert np.hypot(*(seq.gt[k, :2] - seq.gt[k - 1, :2])) > 0.3
    assert np.allclose(seq.odom[k], seq.odom[k - 1])


def test_truth_files(office, tmp_path: Path) -> None:
    seq = simulate(office, seed=1, noise="low", laser=LASER, length=20.0)
    files = write_truth(seq, tmp_path / "t")
    assert {p.name for p in files.values()} == {
        "gt_map.yaml", "visible_map.yaml", "gt_map_start.yaml", "visible_map_start.yaml",
        "gt.tum", "odom.tum", "sequence.json"}
    gt_map = slamq.load_map(files["gt_map"])
    assert np.array_equal(gt_map.values == 0, office.values == 0)
    vis = slamq.load_map(files["visible_map"])
    seen = (vis.values == 0) & ~vis.unknown
    assert seen.any() and not (seen & (office.values != 0)).any()
    assert not (vis.values[~vis.unknown] == 205).any()
    free = (vis.values == 254) & ~vis.unknown
    assert free.any() and (office.values[free] == 254).all()
    gt = slamq.load_trajectory(files["gt"])
    assert np.allclose(gt.positions[:, :2], seq.gt[:, :2])
    assert slamq.ate(gt, slamq.load_trajectory(files["odom"]), align="none").max > 0
    doc = json.loads(files["sequence"].read_text())
    assert doc["scans"] == len(seq) and doc["laser"]["beams"] == 271
    assert doc["meta"]["odometry_noise"]["name"] == "low"
    # the visible map is never larger than the world, and a real comparison runs on it
    cmp = slamq.compare(vis, gt_map, align="origin")
    assert cmp is not None
    # the map in the frame of the first pose: the path moved into that frame lands on the
    # same cells of it as the world path on the world map
    start = slamq.load_map(files["visible_map_start"])
    assert np.array_equal(start.values, vis.values)
    x0, y0, th = seq.gt[0]
    c, s = np.cos(th), np.sin(th)
    local = np.column_stack([c * (seq.gt[:, 0] - x0) + s * (seq.gt[:, 1] - y0),
                             -s * (seq.gt[:, 0] - x0) + c * (seq.gt[:, 1] - y0)])
    ox, oy, oyaw = start.origin
    cw, sw = np.cos(-oyaw), np.sin(-oyaw)
    cells = np.column_stack([cw * (local[:, 0] - ox) - sw * (local[:, 1] - oy),
                             sw * (local[:, 0] - ox) + cw * (local[:, 1] - oy)])
    assert np.allclose(cells, seq.gt[:, :2] - np.array(vis.origin[:2]), atol=1e-9)


def test_visible_map_leaves_out_transparent_walls() -> None:
    hall = world(0, kind="hall", size=(10.0, 8.0))
    seq = simulate(hall, seed=0, noise="none", laser=LASER, length=15.0)
    vis = visible_map(seq)
    assert not ((vis.values == 0) & hall.meta["transparent"]).any()


def test_sequence_npz_round_trip(office, tmp_path: Path) -> None:
    seq = simulate(office, seed=1, laser=LASER, length=8.0)
    back = load_sequence(save_sequence(seq, tmp_path / "s.npz"))
    for f in ("stamps", "gt", "odom", "ranges"):
        assert np.array_equal(getattr(back, f), getattr(seq, f))
    assert back.laser == seq.laser and back.name == seq.name and back.meta == seq.meta
    assert np.array_equal(back.world.values, office.values)
    (tmp_path / "bad.npz").write_bytes(b"nope")
    with pytest.raises(SlamqError, match="bad.npz"):
        load_sequence(tmp_path / "bad.npz")


def test_simulate_bad_input(office, tmp_path: Path) -> None:
    with pytest.raises(SlamqError, match="unknown odometry noise 'loud'"):
        simulate(office, noise="loud")
    with pytest.raises(SlamqError, match="laser: beams"):
        simulate(office, laser=LaserSpec(beams=0))
    with pytest.raises(SlamqError, match="laser: min_range"):
        simulate(office, laser=LaserSpec(min_range=30.0))
    with pytest.raises(SlamqError, match="speed"):
        simulate(office, speed=-1.0)
    with pytest.raises(slamq.errors.MapError, match="missing.yaml"):
        simulate(tmp_path / "missing.yaml")
    with pytest.raises(SlamqError, match="odometry noise"):
        simulate(office, noise={"loudness": 1.0})
    assert math.isclose(NOISE["high"].heading_bias, math.radians(0.5))
