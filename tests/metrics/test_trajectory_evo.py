"""Conformance: slamq's ATE and RPE equal evo's (Python API) to 1e-9.

evo (GPL) is a test extra; its test data is read from ../shared/data (not copied here).
Alignments compared: se3 (evo -a), sim3 (-as), origin (--align_origin), none.
"""

from __future__ import annotations

import copy
import logging
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from slamq.metrics.ate import ate, rpe
from slamq.metrics.sync import matching_indices
from slamq.models import Trajectory
from slamq.sources.trajectories import load_trajectory

evo_metrics = pytest.importorskip("evo.core.metrics")
from evo.core import sync  # noqa: E402
from evo.core.trajectory import PoseTrajectory3D  # noqa: E402
from evo.main_ape import ape as evo_ape  # noqa: E402
from evo.main_rpe import rpe as evo_rpe  # noqa: E402
from evo.tools import file_interface  # noqa: E402

logging.getLogger("evo").setLevel(logging.ERROR)

TOL = 1e-9
STATS = ("rmse", "mean", "median", "std", "min", "max", "sse")
ALIGNS = ("se3", "sim3", "origin", "none")
TRAJ = Path(__file__).resolve().parents[1] / "data" / "trajectories" / "slam_comparison_tools"


def _evo_kw(align: str) -> dict:
    return {"align": align in ("se3", "sim3"), "correct_scale": align == "sim3",
            "align_origin": align == "origin"}


def _to_evo(tr: Trajectory) -> PoseTrajectory3D:
    return PoseTrajectory3D(np.array(tr.positions), np.array(tr.orientations),
                            np.array(tr.timestamps))


def _same(ours, result) -> None:
    errors = result.np_arrays["error_array"]
    assert ours.n == len(errors)
    assert np.max(np.abs(ours.errors - errors)) <= TOL
    for k in STATS:
        ref = float(result.stats[k])
        assert abs(getattr(ours, k) - ref) <= TOL * max(1.0, abs(ref)), (k, ours, ref)


def _check_ape(gt: Trajectory, est: Trajectory, egt, eest, align: str, max_dt=0.01,
               offset=0.0) -> None:
    rg, re_ = sync.associate_trajectories(egt, eest, max_diff=max_dt, offset_2=offset)
    res = evo_ape(copy.deepcopy(rg), copy.deepcopy(re_),
                  evo_metrics.PoseRelation.translation_part, **_evo_kw(align))
    ours = ate(gt, est, align=align, max_dt=max_dt, offset=offset)
    _same(ours, res)
    if align in ("se3", "sim3", "origin"):
        assert np.allclose(ours.alignment.matrix(), res.np_arrays["alignment_transformation_sim3"],
                           atol=1e-9)


def _check_rpe(gt, est, egt, eest, align, delta, unit, relation="trans") -> None:
    rg, re_ = sync.associate_trajectories(egt, eest)
    rel = {"trans": evo_metrics.PoseRelation.translation_part,
           "angle_deg": evo_metrics.PoseRelation.rotation_angle_deg}[relation]
    eunit = evo_metrics.Unit.frames if unit == "frames" else evo_metrics.Unit.meters
    res = evo_rpe(copy.deepcopy(rg), copy.deepcopy(re_), rel, delta=delta, delta_unit=eunit,
                  **_evo_kw(align))
    ours = rpe(gt, est, align=align, delta=delta, unit=unit, relation=relation)
    _same(ours, res)


# ---------------------------------------------------------------- evo's own test data
EVO_PAIRS = [
    ("freiburg1_xyz-groundtruth.txt", "freiburg1_xyz-rgbdslam.txt"),
    ("freiburg1_xyz-groundtruth.txt", "freiburg1_xyz-rgbdslam_drift.txt"),
    ("fr2_desk_groundtruth.txt", "fr2_desk_ORB.txt"),
]


@pytest.fixture(scope="module")
def evo_data(shared_data):
    folder = shared_data / "trajectories" / "evo_testdata_tum_rgbd"
    if not folder.is_dir():
        pytest.skip(f"{folder} not found")
    out = []
    for g, e in EVO_PAIRS:
        gp, ep = folder / g, folder / e
        out.append((load_trajectory(gp), load_trajectory(ep),
                    file_interface.read_tum_trajectory_file(str(gp)),
                    file_interface.read_tum_trajectory_file(str(ep))))
    return out


@pytest.mark.parametrize("align", ALIGNS)
def test_ape_equals_evo_on_tum_rgbd(evo_data, align):
    for gt, est, egt, eest in evo_data:
        _check_ape(gt, est, egt, eest, align)


@pytest.mark.parametrize("align", ALIGNS)
def test_rpe_equals_evo_on_tum_rgbd(evo_data, align):
    gt, est, egt, eest = evo_data[0]
    for delta, unit in ((1, "frames"), (10, "frames"), (0.3, "m")):
        _check_rpe(gt, est, egt, eest, align, delta, unit)
    _check_rpe(gt, est, egt, eest, align, 5, "frames", "angle_deg")


def test_rpe_pairs_from_reference_equals_evo(evo_data):
    gt, est, egt, eest = evo_data[2]
    rg, re_ = sync.associate_trajectories(egt, eest)
    res = evo_rpe(copy.deepcopy(rg), copy.deepcopy(re_), evo_metrics.PoseRelation.translation_part,
                  delta=0.25, delta_unit=evo_metrics.Unit.meters, pairs_from_reference=True,
                  align=True, correct_scale=True)
    _same(rpe(gt, est, delta=0.25, unit="m", pairs_from="gt", align="sim3"), res)


def test_ape_equals_evo_with_max_dt_and_offset(evo_data):
    gt, est, egt, eest = evo_data[2]
    for max_dt, offset in ((0.02, 0.0), (0.005, 0.01), (0.05, -0.03)):
        _check_ape(gt, est, egt, eest, "sim3", max_dt=max_dt, offset=offset)


def test_readers_equal_evo_reader(evo_data):
    for gt, _, egt, _ in evo_data:
        assert np.array_equal(gt.timestamps, egt.timestamps)
        assert np.array_equal(gt.positions, egt.positions_xyz)
        q = egt.orientations_quat_wxyz
        assert np.allclose(gt.orientations, q / np.linalg.norm(q, axis=1, keepdims=True),
                           atol=1e-15)


# ---------------------------------------------------------------- slam_comparison_tools
def _log_pairs() -> list:
    return [pytest.param(log, id=f"{log.parent.name}/{log.stem}")
            for log in sorted(TRAJ.glob("*/*_pose_log.csv"))]


@pytest.mark.parametrize("log", _log_pairs())
def test_ape_rpe_equal_evo_on_pose_logs(log):
    est = load_trajectory(log, columns={"t": "timestamp_sec", "x": "slam_x", "y": "slam_y"},
                          unsorted="last")
    gt = load_trajectory(log, columns={"t": "timestamp_sec", "x": "gt_x", "y": "gt_y"},
                         unsorted="last")
    for align in ALIGNS:
        _check_ape(gt, est, _to_evo(gt), _to_evo(est), align)
    _check_rpe(gt, est, _to_evo(gt), _to_evo(est), "none", 2, "frames")
    _check_rpe(gt, est, _to_evo(gt), _to_evo(est), "sim3", 1.0, "m")
    # on planar logs se2 finds the same alignment as se3
    assert abs(ate(gt, est, align="se2").rmse - ate(gt, est, align="se3").rmse) <= TOL


# ---------------------------------------------------------------- generated trajectories
@st.composite
def trajectory_pairs(draw):
    n = draw(st.integers(8, 60))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    dt = draw(st.sampled_from([0.01, 0.05, 0.1]))
    t = 1000.0 + np.cumsum(rng.uniform(0.5, 1.5, n) * dt)
    pos = np.cumsum(rng.normal(0, 1, (n, 3)), axis=0)
    q = rng.normal(size=(n, 4))
    gt = Trajectory(t, pos, q)
    # estimate: a random similarity of the ground truth, noise, dropped poses, time jitter
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    ang = rng.uniform(-np.pi, np.pi)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    r = np.eye(3) + np.sin(ang) * k + (1 - np.cos(ang)) * k @ k
    scale = rng.uniform(0.3, 3.0)
    ep = scale * pos @ r.T + rng.normal(0, 5, 3) + rng.normal(0, 0.3, (n, 3))
    eq = q + rng.normal(0, 0.1, (n, 4))
    keep = rng.random(n) > 0.2
    keep[:4] = True
    jitter = rng.uniform(-0.2, 0.2, n) * dt  # spacing >= 0.5 dt: stays sorted
    est = Trajectory(t[keep] + jitter[keep], ep[keep], eq[keep])
    max_dt = draw(st.sampled_from([0.01, 0.5 * dt, dt]))
    return gt, est, max_dt


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(trajectory_pairs(), st.sampled_from(ALIGNS))
def test_ape_equals_evo_on_generated_trajectories(pair, align):
    gt, est, max_dt = pair
    egt, eest = _to_evo(gt), _to_evo(est)
    try:
        rg, re_ = sync.associate_trajectories(egt, eest, max_diff=max_dt)
    except sync.SyncException:
        with pytest.raises(Exception, match="no pose is within max_dt"):
            ate(gt, est, align=align, max_dt=max_dt)
        return
    if len(rg.timestamps) < 3 and align in ("se3", "sim3"):
        return  # both refuse (degenerate); covered in test_trajectory.py
    res = evo_ape(copy.deepcopy(rg), copy.deepcopy(re_),
                  evo_metrics.PoseRelation.translation_part, **_evo_kw(align))
    _same(ate(gt, est, align=align, max_dt=max_dt), res)


@settings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(trajectory_pairs(), st.sampled_from([("frames", 1), ("frames", 3), ("m", 2.0)]),
       st.sampled_from(["trans", "angle_deg"]))
def test_rpe_equals_evo_on_generated_trajectories(pair, delta_unit, relation):
    gt, est, _ = pair
    unit, delta = delta_unit
    egt, eest = _to_evo(gt), _to_evo(est)
    try:
        rg, re_ = sync.associate_trajectories(egt, eest, max_diff=0.1)
    except sync.SyncException:
        return
    rel = {"trans": evo_metrics.PoseRelation.translation_part,
           "angle_deg": evo_metrics.PoseRelation.rotation_angle_deg}[relation]
    eunit = evo_metrics.Unit.frames if unit == "frames" else evo_metrics.Unit.meters
    try:
        res = evo_rpe(copy.deepcopy(rg), copy.deepcopy(re_), rel, delta=delta,
                      delta_unit=eunit)
    except Exception as exc:  # evo: no pair for this delta
        assert "empty index list" in str(exc)
        with pytest.raises(Exception, match="no pose pair"):
            rpe(gt, est, delta=delta, unit=unit, relation=relation, max_dt=0.1)
        return
    _same(rpe(gt, est, delta=delta, unit=unit, relation=relation, max_dt=0.1), res)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(0, 100, allow_nan=False), min_size=1, max_size=40),
       st.lists(st.floats(0, 100, allow_nan=False), min_size=1, max_size=40),
       st.sampled_from([0.0, 0.01, 0.5, 3.0]), st.sampled_from([0.0, 0.25, -1.5]))
def test_matching_equals_evo(s1, s2, max_dt, offset):
    a = np.array(s1)
    b = np.sort(np.array(s2))
    i1, i2 = matching_indices(a, b, max_dt, offset)
    e1, e2 = sync.matching_time_indices(a, b, max_dt, offset)
    assert i1.tolist() == e1 and i2.tolist() == e2
