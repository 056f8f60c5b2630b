"""A map against its own scans (docs/spec.md 7b, slamq.metrics.scans): the exact map of a
simulated world agrees with its scans, damaged or misplaced maps do not, and the Rust core
gives the numpy twin's integers for any thread count."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from slamq import native
from slamq.errors import SequenceError, SlamqError
from slamq.metrics.scans import scan_consistency, scan_consistency_reference
from slamq.models import OccupancyMap, ScanConsistency, Scans, Trajectory
from slamq.synth import LaserSpec, degrade, simulate, world


@pytest.fixture(scope="module")
def drive():
    """A small office world, a drive with noisy odometry, 91-beam scans."""
    w = world(3, kind="office", size=(10.0, 8.0))
    seq = simulate(w, seed=1, noise="high", laser=LaserSpec(beams=91), length=20.0)
    return w, seq, Scans.from_sequence(seq)


def _moved(m: OccupancyMap, dx: float = 0.0, dy: float = 0.0, dyaw: float = 0.0
           ) -> OccupancyMap:
    x, y, yaw = m.origin
    return OccupancyMap(m.values, m.unknown, m.resolution, (x + dx, y + dy, yaw + dyaw),
                        source="moved")


def test_the_exact_map_at_the_exact_poses_agrees_with_its_scans(drive) -> None:
    w, seq, scans = drive
    c = scan_consistency(w, scans, seq.gt)
    assert isinstance(c, ScanConsistency)
    assert c.scans == len(seq) and c.beams > 0.5 * len(seq) * 91
    assert c.hit_share > 0.99
    assert c.violation_share < 0.005
    assert c.outside_share == 0.0 and c.unknown_share == 0.0
    assert c.violation_grid.shape == w.shape and c.violation_grid.dtype == np.uint32
    # every per-scan figure is a share of that scan's valid beams
    assert np.all((c.hit_shares >= 0) & (c.hit_shares <= 1))
    assert (c.counts[:, 1:5].sum(axis=1) == c.counts[:, 0]).all()


def test_a_trajectory_is_placed_at_the_scan_stamps(drive) -> None:
    w, seq, scans = drive
    tr = Trajectory.from_xy_yaw(seq.stamps, seq.gt[:, 0], seq.gt[:, 1], seq.gt[:, 2])
    c = scan_consistency(w, scans, tr)
    assert c.placed.all()
    assert c.hit_share == pytest.approx(scan_consistency(w, scans, seq.gt).hit_share, abs=1e-3)
    # a trajectory covering the first half only: the other scans are left out
    half = len(seq) // 2
    part = Trajectory.from_xy_yaw(seq.stamps[:half], seq.gt[:half, 0], seq.gt[:half, 1],
                                  seq.gt[:half, 2])
    c = scan_consistency(w, scans, part)
    assert c.placed.sum() == half and not c.placed[half:].any()
    assert (c.counts[half:] == 0).all() and c.scans == half
    assert np.isnan(c.hit_shares[half:]).all()


@pytest.mark.parametrize("how", ["odometry", "shifted", "turned", "wall removed"])
def test_a_misplaced_or_incomplete_map_agrees_less(drive, how: str) -> None:
    w, seq, scans = drive
    clean = scan_consistency(w, scans, seq.gt)
    poses = seq.gt
    m = w
    if how == "odometry":
        poses = seq.odom
    elif how == "shifted":
        m = _moved(w, 0.3, -0.2)
    elif how == "turned":
        m = _moved(w, dyaw=math.radians(3.0))
    else:
        # every wall of the middle third of the map's columns removed
        v = w.values.copy()
        third = slice(w.shape[1] // 3, 2 * w.shape[1] // 3)
        v[:, third] = np.where(v[:, third] < 128, 254, v[:, third])
        m = OccupancyMap(v, w.unknown, w.resolution, w.origin)
    c = scan_consistency(m, scans, poses)
    assert c.hit_share < clean.hit_share - 0.05
    if how != "wall removed":
        assert c.violation_share > clean.violation_share + 0.05
        assert c.violation_grid.sum() > clean.violation_grid.sum()


@pytest.mark.parametrize("kind,severity", [("doubling", 0.4), ("rotation", 2.0),
                                           ("drift", 2.0), ("specks", 0.01)])
def test_a_damaged_map_scores_worse_than_the_clean_one(drive, kind: str, severity: float
                                                       ) -> None:
    w, seq, scans = drive
    clean = scan_consistency(w, scans, seq.gt)
    c = scan_consistency(degrade(w, kind, severity, seed=1), scans, seq.gt)
    assert c.violation_share > clean.violation_share + 0.02
    assert c.hit_share <= clean.hit_share


def test_the_violation_grid_marks_the_ghost_wall() -> None:
    v = np.full((20, 30), 254, np.uint8)
    v[:, 25] = 0          # the real wall, x in [2.5, 2.6]
    v[8:12, 15] = 0       # a ghost wall some scans see through, x in [1.5, 1.6]
    m = OccupancyMap(v, np.zeros_like(v, bool), 0.1)
    angles = np.linspace(-0.3, 0.3, 31)
    ranges = (2.5 - 0.5) / np.cos(angles)[None, :]
    c = scan_consistency(m, Scans([0.0], angles, ranges, 10.0), [[0.5, 1.0, 0.0]])
    assert c.counts[0, 0] == 31 and c.counts[0, 1] == 31
    assert 0 < c.counts[0, 5] < 31
    # the beams through the ghost wall come out into the free room behind it: crossings
    assert c.counts[0, 6] == c.counts[0, 5]
    assert set(np.flatnonzero(c.violation_grid.sum(axis=0))) == {15}


def _thickened(m: OccupancyMap, cells: int) -> OccupancyMap:
    """Every wall drawn ``cells`` cells thicker on each side (as a coarse or blurred map
    draws it): beams running along a wall clip it."""
    import cv2

    wall = ((m.values < 128) & ~m.unknown).astype(np.uint8)
    thick = cv2.dilate(wall, np.ones((2 * cells + 1, 2 * cells + 1), np.uint8)) > 0
    return OccupancyMap(np.where(thick, 0, m.values).astype(np.uint8), m.unknown,
                        m.resolution, m.origin, source="thick")


def test_a_wall_drawn_thick_is_grazed_not_crossed(drive) -> None:
    w, seq, scans = drive
    clean = scan_consistency(w, scans, seq.gt)
    thick = scan_consistency(_thickened(w, 2), scans, seq.gt)
    # beams running along a wall drawn 0.1 m too thick clip it: most of them violate, but
    # few come out into free space beyond a wall (those passing a door's jamb do)
    assert clean.violation_share < 0.005 and clean.crossing_share < 0.005
    assert thick.violation_share > 0.5
    assert thick.crossing_share < 0.15 * thick.violation_share
    # the heat map's grid holds the crossing beams only
    assert (thick.crossing_grid <= thick.violation_grid).all()
    assert thick.crossing_grid.sum() < 0.5 * thick.violation_grid.sum()
    assert (thick.counts[:, 6] <= thick.counts[:, 5]).all()


@pytest.mark.parametrize("how", ["odometry", "shifted", "turned"])
def test_a_misplaced_map_is_crossed(drive, how: str) -> None:
    w, seq, scans = drive
    clean = scan_consistency(w, scans, seq.gt)
    poses, m = seq.gt, w
    if how == "odometry":
        poses = seq.odom
    elif how == "shifted":
        m = _moved(w, 0.3, -0.2)
    else:
        m = _moved(w, dyaw=math.radians(3.0))
    c = scan_consistency(m, scans, poses)
    assert c.crossing_share > clean.crossing_share + 0.02


def test_the_laser_offset_is_applied() -> None:
    v = np.full((10, 10), 254, np.uint8)
    v[:, 7] = 0
    m = OccupancyMap(v, np.zeros_like(v, bool), 0.1)
    s = Scans([0.0], [0.0], [[0.26]], 20.0, offset=(0.2, 0.0, 0.0))
    assert scan_consistency(m, s, [[0.25, 0.55, 0.0]]).counts[0, 1] == 1
    s = Scans([0.0], [0.0], [[0.46]], 20.0, offset=(0.2, 0.0, 0.0))
    assert scan_consistency(m, s, [[0.25, 0.55, 0.0]]).counts[0, 5] == 1


@st.composite
def cases(draw):
    h, w = draw(st.integers(1, 14)), draw(st.integers(1, 14))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    values = rng.choice(np.array([0, 100, 127, 128, 200, 254], np.uint8), size=(h, w),
                        p=[0.2, 0.05, 0.05, 0.05, 0.05, 0.6])
    unknown = rng.random((h, w)) < draw(st.sampled_from([0.0, 0.2]))
    res = draw(st.sampled_from([0.05, 0.1, 0.3]))
    origin = (draw(st.floats(-1, 1)), draw(st.floats(-1, 1)),
              draw(st.sampled_from([0.0, 0.3, -math.pi / 2, 2.0])))
    m = OccupancyMap(values, unknown, res, origin)
    n, b = draw(st.integers(1, 4)), draw(st.integers(1, 24))
    span = max(h, w) * res
    poses = np.column_stack([rng.uniform(-1, span + 1, n), rng.uniform(-1, span + 1, n),
                             rng.uniform(-4, 4, n)])
    # a few poses on cell boundaries and beams along the axes (ties at cell corners)
    if draw(st.booleans()):
        poses[0, :2] = np.round(poses[0, :2] / res) * res
        poses[0, 2] = 0.0
    angles = np.linspace(-math.pi, math.pi, b) if draw(st.booleans()) else rng.uniform(-3, 3, b)
    ranges = rng.uniform(0.0, 1.3 * span, (n, b))
    ranges[rng.random((n, b)) < 0.1] = np.inf
    ranges[rng.random((n, b)) < 0.05] = np.nan
    scans = Scans(np.arange(n, dtype=float), angles, ranges,
                  draw(st.sampled_from([math.inf, span + 0.2])), min_range=draw(
                      st.sampled_from([0.0, 0.1])))
    tol = draw(st.sampled_from([0.02, 0.1, 0.25, 0.6]))
    return m, scans, poses, tol


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(cases())
def test_rust_equals_the_numpy_twin(case) -> None:
    m, scans, poses, tol = case
    rust = scan_consistency(m, scans, poses, scan_tolerance=tol, threads=1)
    ref = scan_consistency_reference(m, scans, poses, scan_tolerance=tol)
    assert np.array_equal(rust.counts, ref.counts)
    assert np.array_equal(rust.violation_grid, ref.violation_grid)
    assert np.array_equal(rust.crossing_grid, ref.crossing_grid)
    assert np.array_equal(rust.placed, ref.placed)


def test_the_twin_agrees_on_a_simulated_drive(drive) -> None:
    w, seq, scans = drive
    short = Scans(scans.stamps[:25], scans.angles, scans.ranges[:25], scans.max_range)
    rust = scan_consistency(w, short, seq.odom[:25])
    ref = scan_consistency_reference(w, short, seq.odom[:25])
    assert np.array_equal(rust.counts, ref.counts)
    assert np.array_equal(rust.violation_grid, ref.violation_grid)
    assert np.array_equal(rust.crossing_grid, ref.crossing_grid)
    assert rust.counts[:, 5].sum() > 0
    assert rust.counts[:, 6].sum() > 0
    assert 0 < rust.crossing_grid.sum() and (rust.crossing_grid <= rust.violation_grid).all()


def test_thread_counts_give_the_same_result(drive) -> None:
    w, seq, scans = drive
    one = scan_consistency(w, scans, seq.odom, threads=1)
    two = scan_consistency(w, scans, seq.odom, threads=2)
    assert np.array_equal(one.counts, two.counts)
    assert np.array_equal(one.violation_grid, two.violation_grid)
    assert np.array_equal(one.crossing_grid, two.crossing_grid)
    assert one.violation_grid.sum() > 0


def test_bad_input_is_refused_with_its_name() -> None:
    v = np.full((4, 4), 254, np.uint8)
    m = OccupancyMap(v, np.zeros_like(v, bool), 0.1, source="room.yaml")
    s = Scans([0.0, 1.0], [0.0], [[1.0], [1.0]], 5.0, source="laser.log")
    with pytest.raises(SlamqError, match=r"laser.log: poses must be .*\(2, 3\)"):
        scan_consistency(m, s, np.zeros((3, 3)))
    with pytest.raises(SlamqError, match="resolution"):
        scan_consistency(OccupancyMap(v, np.zeros_like(v, bool)), s, np.zeros((2, 3)))
    with pytest.raises(SlamqError, match="scan_tolerance"):
        scan_consistency(m, s, np.zeros((2, 3)), scan_tolerance=0.0)
    with pytest.raises(SlamqError, match="room.yaml with laser.log: tolerance"):
        scan_consistency(m, s, np.zeros((2, 3)), scan_tolerance=1e3)
    with pytest.raises(SequenceError, match="ranges must have shape"):
        Scans([0.0, 1.0], [0.0, 0.1], [[1.0], [1.0]], 5.0)
    with pytest.raises(SequenceError, match="min_range"):
        Scans([0.0], [0.0], [[1.0]], 5.0, min_range=6.0)
    with pytest.raises(SequenceError, match="non-decreasing"):
        Scans([1.0, 0.0], [0.0], [[1.0], [1.0]], 5.0)
    # the core itself names the inputs
    u = np.zeros((4, 4), bool)
    with pytest.raises(ValueError, match="ranges must have shape"):
        native.scan_consistency(v, u, 0.1, (0.0, 0.0, 0.0), 0.5, 0.1, np.zeros((2, 3)),
                                np.zeros(3), np.zeros((2, 2)), 0.0, 5.0)
    with pytest.raises(ValueError, match="poses must have shape"):
        native.scan_consistency(v, u, 0.1, (0.0, 0.0, 0.0), 0.5, 0.1, np.zeros((2, 2)),
                                np.zeros(3), np.zeros((2, 3)), 0.0, 5.0)
    with pytest.raises(ValueError, match="unknown mask shape"):
        native.scan_consistency(v, u[:2], 0.1, (0.0, 0.0, 0.0), 0.5, 0.1, np.zeros((2, 3)),
                                np.zeros(3), np.zeros((2, 3)), 0.0, 5.0)
    with pytest.raises(ValueError, match="pose 1 must be finite"):
        native.scan_consistency(v, u, 0.1, (0.0, 0.0, 0.0), 0.5, 0.1,
                                np.array([[0.0, 0, 0], [np.nan, 0, 0]]), np.zeros(3),
                                np.zeros((2, 3)), 0.0, 5.0)
