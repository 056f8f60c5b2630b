"""Interpolated association and the time-offset search of ATE / RPE (docs/spec.md 6b);
without them the numbers are evo's (tests/metrics/test_trajectory_evo.py)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from slamq.cli import main
from slamq.errors import TrajectoryError
from slamq.metrics.ate import ate, find_offset, rpe
from slamq.metrics.sync import associate_interpolated, interpolate_poses, slerp
from slamq.models import Trajectory
from slamq.models.trajectory import quat_multiply, yaw_to_quat


def _curve(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return 3 * np.cos(0.2 * t), 2 * np.sin(0.3 * t), 0.1 * t


def _pair(offset: float = 0.0) -> tuple[Trajectory, Trajectory]:
    """Ground truth at 50 Hz and an estimate at 5 Hz of the same smooth path, whose clock
    reads ``offset`` s behind (its stamps + offset = true time)."""
    tg = np.arange(0.0, 60.0, 0.02)
    te = np.arange(0.013, 60.0, 0.2)
    gt = Trajectory.from_xy_yaw(tg, *_curve(tg))
    est = Trajectory.from_xy_yaw(te - offset, *_curve(te))
    return gt, est


def test_without_the_new_keywords_nothing_changes() -> None:
    gt, est = _pair()
    a = ate(gt, est, max_dt=0.02)
    b = ate(gt, est, max_dt=0.02, offset=0.0, interpolate=False)
    assert a.rmse == b.rmse and a.n == b.n
    assert set(a.params) == {"max_dt", "offset"}
    r = rpe(gt, est, max_dt=0.02)
    assert set(r.params) == {"max_dt", "offset", "delta", "unit", "relation"}


def test_interpolation_pairs_every_ground_truth_pose_inside_the_estimate() -> None:
    gt, est = _pair()
    near = ate(gt, est, max_dt=0.02, align="none")
    inter = ate(gt, est, interpolate=True, align="none")
    inside = (gt.timestamps >= est.timestamps[0]) & (gt.timestamps <= est.timestamps[-1])
    assert inter.n == int(inside.sum()) > 5 * near.n
    # the chord between 5 Hz samples of a smooth curve is close to it
    assert inter.rmse < 2e-3 and inter.params["interpolate"] is True
    # on a straight line at constant speed interpolation is exact
    t = np.arange(0.0, 10.0, 0.1)
    line = Trajectory.from_xy_yaw(t, 2 * t, -t, 0 * t)
    sparse = Trajectory.from_xy_yaw(t[::7], 2 * t[::7], -t[::7], 0 * t[::7])
    assert ate(line, sparse, interpolate=True, max_gap=1.0, align="none").rmse < 1e-12
    assert ate(line, sparse, interpolate=True, max_gap=0.5, align="none").n == 1 + 14


def test_interpolation_respects_max_gap_and_says_when_nothing_is_left() -> None:
    gt, est = _pair()
    with pytest.raises(TrajectoryError, match="no ground-truth pose.*max_gap 0.1"):
        ate(gt, est, interpolate=True, max_gap=0.1)
    with pytest.raises(TrajectoryError, match="max_gap must be"):
        ate(gt, est, interpolate=True, max_gap=float("nan"))


def test_slerp_and_the_interpolated_orientation() -> None:
    a, b = yaw_to_quat(np.array([0.2])), yaw_to_quat(np.array([1.4]))
    q = slerp(a, b, np.array([0.25]))
    np.testing.assert_allclose(q, yaw_to_quat(np.array([0.5])), atol=1e-12)
    # 3-D: halfway between identity and 90 deg about x is 45 deg about x
    rx = np.array([[np.cos(np.pi / 4), np.sin(np.pi / 4), 0, 0]])
    half = slerp(np.array([[1.0, 0, 0, 0]]), rx, np.array([0.5]))
    np.testing.assert_allclose(quat_multiply(half[0], half[0]), rx[0], atol=1e-12)
    tr = Trajectory.from_xy_yaw([0.0, 1.0], [0, 0], [0, 0], [0.2, 1.4])
    ok, interp, _, o = interpolate_poses(tr, np.array([0.25]), max_gap=1.0)
    assert ok.all() and interp.all()
    np.testing.assert_allclose(o, yaw_to_quat(np.array([0.5])), atol=1e-12)
    gi, e = associate_interpolated(tr, tr, max_gap=1.0)
    assert gi.tolist() == [0, 1] and e.positions.tolist() == tr.positions.tolist()


@pytest.mark.parametrize("true_offset", [0.0, 0.237, -0.61])
def test_the_offset_search_finds_the_clock_offset(true_offset: float) -> None:
    gt, est = _pair(true_offset)
    found, rmse, evaluations = find_offset(gt, est, interpolate=True)
    assert found == pytest.approx(true_offset, abs=2e-3)
    assert evaluations < 120 and rmse < 5e-3
    r = ate(gt, est, interpolate=True, offset="auto")
    assert r.params["offset"] == found and r.params["offset_search"]["max_offset"] == 1.0
    assert r.rmse == pytest.approx(ate(gt, est, interpolate=True, offset=found).rmse)
    if true_offset:
        assert r.rmse < 0.1 * ate(gt, est, interpolate=True).rmse
    rr = rpe(gt, est, interpolate=True, offset="auto", delta=10)
    assert rr.params["offset"] == found


def test_the_offset_search_is_bounded() -> None:
    gt, est = _pair(0.8)
    found, _, _ = find_offset(gt, est, interpolate=True, max_offset=0.3)
    assert abs(found) <= 0.3
    with pytest.raises(TrajectoryError, match="max_offset"):
        find_offset(gt, est, max_offset=-1)
    with pytest.raises(TrajectoryError, match="'auto'"):
        ate(gt, est, offset="automatic")  # type: ignore[arg-type]


def test_cli_interpolate_and_time_offset(tmp_path: Path, capsys) -> None:
    gt, est = _pair(0.237)
    g = gt.write_tum(tmp_path / "gt.txt")
    e = est.write_tum(tmp_path / "est.txt")
    out = tmp_path / "ate.json"
    assert main(["ate", str(g), str(e), "--interpolate", "--time-offset", "auto",
                 "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "interpolated" in text and "time offset found for" in text and "+0.237" in text
    (res,) = json.loads(out.read_text())["results"]
    assert res["offset"] == pytest.approx(0.237, abs=2e-3) and res["interpolate"] is True
    assert main(["rpe", str(g), str(e), "--interpolate", "--time-offset", "0.237",
                 "--max-gap", "0.3"]) == 0
    assert "interpolated" in capsys.readouterr().out
    assert main(["ate", str(g), str(e), "--time-offset", "auto", "--offset", "0.1"]) == 2
    assert "both set" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:
        main(["ate", str(g), str(e), "--time-offset", "soon"])
    assert exc.value.code == 2
    assert "'auto' or seconds" in capsys.readouterr().err
