"""A trajectory against its own scans, split in time (docs/spec.md 7e, slamq.metrics.split):
the exact path of a simulated drive agrees with itself, its odometry does not, and the
Rust core gives the numpy twin's maps and integers for any thread count, on simulated,
random and real scans."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import SHARED_DATA
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from slamq import load_scans, native, scan_split
from slamq.errors import SlamqError
from slamq.metrics.split import (
    LOCAL_WINDOWS,
    local_split,
    local_split_reference,
    local_windows,
    scan_split_reference,
)
from slamq.models import OccupancyMap, Scans, ScanSplit, Trajectory
from slamq.synth import LaserSpec, simulate, world


@pytest.fixture(scope="module")
def drive():
    """An office world, a drive with noisy odometry, 181-beam scans."""
    w = world(3, kind="office", size=(12.0, 9.0))
    seq = simulate(w, seed=4, noise="high", laser=LaserSpec(beams=181), length=40.0)
    return seq, Scans.from_sequence(seq)


def _same(a: ScanSplit, b: ScanSplit) -> None:
    for i in range(2):
        assert np.array_equal(a.counts[i], b.counts[i])
        assert np.array_equal(a.drawn[i], b.drawn[i])
        assert np.array_equal(a.tested[i], b.tested[i])
        assert np.array_equal(a.maps[i].values, b.maps[i].values)
        assert np.array_equal(a.maps[i].unknown, b.maps[i].unknown)
        assert a.maps[i].origin == b.maps[i].origin
    assert np.array_equal(a.placed, b.placed)


def test_the_true_path_agrees_with_itself_and_odometry_does_not(drive) -> None:
    seq, scans = drive
    gt = scan_split(scans, seq.gt)
    odom = scan_split(scans, seq.odom)
    assert isinstance(gt, ScanSplit)
    assert gt.crossing_share < 0.005
    assert odom.crossing_share > 3 * gt.crossing_share
    assert (gt.hit_shares > 0.35).all() and (odom.hit_shares < 0.5 * gt.hit_shares).all()
    # the maps cover the drive: walls, free space, unknown beyond
    for m in gt.maps:
        assert isinstance(m, OccupancyMap) and m.resolution == 0.05 and m.origin[2] == 0.0
        assert {0, 254, 205} == set(np.unique(m.values).tolist())
        assert np.array_equal(m.unknown, m.values == 205)
    # every placed scan is drawn by one half and scored against the other's map
    n = len(scans)
    assert gt.placed.all()
    assert np.array_equal(np.sort(np.concatenate(gt.drawn)), np.arange(n))
    assert np.array_equal(gt.drawn[0], gt.tested[1]) and gt.drawn[0].max() < gt.drawn[1].min()
    assert gt.to_dict()["split_crossing"] == gt.crossing_share


def test_a_trajectory_is_placed_at_the_scan_stamps(drive) -> None:
    seq, scans = drive
    tr = Trajectory.from_xy_yaw(seq.stamps, *seq.gt.T)
    assert scan_split(scans, tr).crossing_share == pytest.approx(
        scan_split(scans, seq.gt).crossing_share, abs=2e-3)
    half = len(seq) // 2
    part = Trajectory.from_xy_yaw(seq.stamps[:half], *seq.gt[:half].T)
    s = scan_split(scans, part)
    assert s.placed.sum() == half and s.drawn[1].max() < half


def test_the_spread_caps_drawn_and_tested_scans(drive) -> None:
    seq, scans = drive
    s = scan_split(scans, seq.odom, max_draw=20, max_test=7)
    assert [len(d) for d in s.drawn] == [20, 20]
    assert [len(t) for t in s.tested] == [7, 7]
    assert [c.shape for c in s.counts] == [(7, 7), (7, 7)]
    assert s.tested[0].min() >= s.drawn[1].min() and s.tested[1].max() <= s.drawn[0].max()


def test_the_core_equals_the_numpy_twin_on_a_drive(drive) -> None:
    seq, scans = drive
    for poses in (seq.gt, seq.odom):
        rust = scan_split(scans, poses, max_draw=60, max_test=30)
        ref = scan_split_reference(scans, poses, max_draw=60, max_test=30)
        _same(rust, ref)
    assert rust.counts[0][:, 6].sum() > 0


def test_thread_counts_give_the_same_result(drive) -> None:
    seq, scans = drive
    _same(scan_split(scans, seq.odom, threads=1), scan_split(scans, seq.odom, threads=2))


@st.composite
def cases(draw):
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    n, b = draw(st.integers(2, 9)), draw(st.integers(1, 30))
    res = draw(st.sampled_from([0.05, 0.1, 0.25]))
    poses = np.column_stack([rng.uniform(-2, 2, n), rng.uniform(-2, 2, n),
                             rng.uniform(-4, 4, n)])
    # poses on cell boundaries and beams along the axes (ties at cell corners)
    if draw(st.booleans()):
        poses[:, :2] = np.round(poses[:, :2] / res) * res
        poses[:, 2] = 0.0
    angles = (np.linspace(-math.pi, math.pi, b) if draw(st.booleans())
              else rng.uniform(-3, 3, b))
    ranges = rng.uniform(0.0, 3.0, (n, b))
    if draw(st.booleans()):
        ranges = np.round(ranges / res) * res
    ranges[rng.random((n, b)) < 0.1] = np.inf
    ranges[rng.random((n, b)) < 0.05] = np.nan
    scans = Scans(np.arange(n, dtype=float), angles, ranges,
                  draw(st.sampled_from([math.inf, 2.5])),
                  min_range=draw(st.sampled_from([0.0, 0.1])))
    share = draw(st.sampled_from([0.2, 0.5, 1.0]))
    return scans, poses, res, share


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(cases())
def test_rust_equals_the_numpy_twin(case) -> None:
    scans, poses, res, share = case
    try:
        rust = scan_split(scans, poses, resolution=res, occupied_share=share, threads=1)
    except SlamqError as exc:
        # fewer than two scans placed
        assert "place" in str(exc)
        return
    ref = scan_split_reference(scans, poses, resolution=res, occupied_share=share)
    _same(rust, ref)


def _carmen(path, most: int) -> tuple[Scans, Trajectory]:
    """The first ``most`` scans of a CARMEN log and the odometry its laser lines carry."""
    from slamq.sources.carmen import CarmenLog

    odom = [(x.stamp, *x.odom) for x in CarmenLog(path).scans()]
    t, x, y, yaw = np.array(sorted(odom)).T
    s = load_scans(path)
    part = Scans(s.stamps[:most], s.angles, s.ranges[:most], s.max_range,
                 min_range=s.min_range, source=s.source)
    return part, Trajectory.from_xy_yaw(t, x, y, yaw)


def test_the_core_equals_the_twin_on_a_real_log() -> None:
    """The Intel Research Lab's scans at their raw odometry (a path that drifts)."""
    log = SHARED_DATA / "datasets2d" / "intel" / "intel.from-rosbag.clf"
    if not log.is_file():
        pytest.skip(f"{log} not found (the datasets2d corpus beside the clone)")
    scans, odom = _carmen(log, 1500)
    rust = scan_split(scans, odom, max_draw=80, max_test=40)
    _same(rust, scan_split_reference(scans, odom, max_draw=80, max_test=40))
    assert rust.placed.sum() > 1400
    assert rust.counts[0][:, 0].sum() > 1000 and rust.crossing_share > 0


def test_a_building_over_two_hundred_metres_is_split_as_a_small_one() -> None:
    """Two rooms 210 m apart (18 Mcells at 0.05 m, over the 2^24 cells above which the
    halves are drawn one after the other): right poses cross nothing, a scan placed 1.5 m
    off is crossed, and the core equals the twin."""
    a = np.linspace(0.0, 2.0 * np.pi, 8, endpoint=False)   # a laser looking all round
    n = 8
    s = Scans(np.arange(float(n)), a, np.full((n, a.size), 1.03), 10.0, source="big.log")
    right = np.zeros((n, 3))
    right[1::2, :2] = 210.0                                  # every other scan far away
    good = scan_split(s, right)
    assert good.maps[0].values.size > 1 << 24
    assert good.crossing_share == 0.0
    wrong = right.copy()
    wrong[5, 0] += 1.5                                       # one scan of half 2 off
    off = scan_split(s, wrong)
    assert off.crossing_share > 0.0
    _same(off, scan_split_reference(s, wrong))


def test_bad_input_is_refused_with_its_name() -> None:
    s = Scans([0.0, 1.0], [0.0], [[1.0], [1.0]], 5.0, source="laser.log")
    ok = np.zeros((2, 3))
    with pytest.raises(SlamqError, match=r"laser.log: poses must be .*\(2, 3\)"):
        scan_split(s, np.zeros((3, 3)))
    with pytest.raises(SlamqError, match="laser.log: the poses place 1 of 2 scans"):
        scan_split(s, np.array([[0.0, 0.0, 0.0], [np.nan, 0.0, 0.0]]))
    for kw, what in ((dict(resolution=0.0), "resolution"),
                     (dict(occupied_share=0.0), "occupied_share"),
                     (dict(scan_tolerance=-1.0), "scan_tolerance"),
                     (dict(max_draw=0), "max_draw"),
                     (dict(max_draw=70000), "max_draw")):
        with pytest.raises(SlamqError, match=what):
            scan_split(s, ok, **kw)
    far = np.array([[0.0, 0.0, 0.0], [1e6, 0.0, 0.0]])
    with pytest.raises(SlamqError, match="laser.log: .* more than 67108864 cells"):
        scan_split(s, far)
    with pytest.raises(SlamqError, match="laser.log: .* more than 67108864 cells"):
        scan_split_reference(s, far)
    # no valid beam: nothing drawn and nothing scored, so no figure
    blind = Scans([0.0, 1.0], [0.0], [[np.inf], [np.inf]], 5.0, source="laser.log")
    assert math.isnan(scan_split(blind, ok).crossing_share)
    with pytest.raises(SlamqError, match="tolerance"):
        scan_split(s, ok, scan_tolerance=100.0)
    # the core itself names the inputs
    i = np.zeros(1, np.int64)
    with pytest.raises(ValueError, match="ranges must have shape"):
        native.scan_split(ok, np.zeros(2), np.zeros((2, 1)), 0.0, 5.0, i, i, i, i, 0.05,
                          1.0, 0.5, 0.1)
    with pytest.raises(ValueError, match=r"drawn_2: scan 7 is not in 0..2"):
        native.scan_split(ok, np.zeros(1), np.ones((2, 1)), 0.0, 5.0, i, i, i + 7, i, 0.05,
                          1.0, 0.5, 0.1)
    with pytest.raises(ValueError, match=r"tested_1: scan -1"):
        native.scan_split(ok, np.zeros(1), np.ones((2, 1)), 0.0, 5.0, i, i - 1, i, i, 0.05,
                          1.0, 0.5, 0.1)


def test_the_local_share_sees_the_place_not_the_drift(drive) -> None:
    """docs/spec.md 7f: a path laid 1 m off from its middle on (a failed closure) is wrong
    between its halves, not within short stretches: its local share stays near the true
    path's while its split share does not; the core and the numpy twin give the same
    windows and shares, for any thread count."""
    seq, scans = drive
    jump = seq.gt.copy()
    jump[len(jump) // 2:, 0] += 1.0
    gt, off = local_split(scans, seq.gt), local_split(scans, jump)
    assert 1 <= len(gt) <= LOCAL_WINDOWS and len(gt) == len(off)
    assert np.nanmean(gt) < 0.01
    # only the window that holds the jump sees it
    assert (np.abs(off - gt) > 0.005).sum() == 1
    assert scan_split(scans, jump).crossing_share > 3 * scan_split(scans, seq.gt).crossing_share
    small = {"window": 4.0, "max_scans": 20, "max_windows": 3}
    ref = local_split_reference(scans, seq.odom, **small)
    assert np.array_equal(local_split(scans, seq.odom, threads=1, **small), ref)
    assert np.array_equal(local_split(scans, seq.odom, threads=2, **small), ref)
    # a trajectory that places none of the scans has no window
    far = Trajectory.from_xy_yaw(seq.stamps + 1e6, *seq.gt.T)
    assert local_split(scans, far).size == 0


def test_the_windows_follow_the_travel() -> None:
    xy = np.column_stack([np.r_[np.zeros(30), np.arange(1.0, 31.0)], np.zeros(60)])
    w = local_windows(xy, window=10.0, max_scans=15, min_scans=8, max_windows=12)
    # standing still, then 1 m a scan: the first window holds the 30 scans standing and
    # the first 10 m, thinned to 15; then 11-scan windows of 10 m; the last (9 m) kept
    assert [len(x) for x in w] == [15, 11, 9] and w[0][0] == 0 and w[0][-1] == 39
    assert [len(x) for x in local_windows(xy, window=10.0, max_windows=2)] == [40, 9]
    assert local_windows(xy[:5], window=10.0) == []
    with pytest.raises(SlamqError, match="window > 0"):
        local_windows(xy, window=0.0)
