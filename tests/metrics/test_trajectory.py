"""Trajectories: readers, Trajectory, association, alignment, ATE/RPE, runs, CLI.

Conformance with evo is in test_trajectory_evo.py.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import slamq
from slamq.cli import main
from slamq.errors import SlamqError, TrajectoryError
from slamq.metrics.ate import ate, ate_runs, rpe
from slamq.metrics.sync import associate
from slamq.models import Trajectory
from slamq.models.trajectory import matrix_to_quat, quat_to_matrix
from slamq.sources.trajectories import load_trajectory, parse_columns

TRAJ = Path(__file__).resolve().parents[1] / "data" / "trajectories" / "slam_comparison_tools"
SLAM = {"t": "timestamp_sec", "x": "slam_x", "y": "slam_y"}
GT = {"t": "timestamp_sec", "x": "gt_x", "y": "gt_y"}


def _planar(n: int = 200, seed: int = 0) -> Trajectory:
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.1
    yaw = np.cumsum(rng.normal(0, 0.05, n))
    step = rng.uniform(0.05, 0.15, n)
    x = np.cumsum(step * np.cos(yaw))
    y = np.cumsum(step * np.sin(yaw))
    return Trajectory.from_xy_yaw(t, x, y, yaw)


def _moved(tr: Trajectory, yaw: float, shift, noise: float = 0.0, seed: int = 1) -> Trajectory:
    """``tr`` rotated by ``yaw`` about z and shifted, plus position noise."""
    c, s = np.cos(yaw), np.sin(yaw)
    r = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])
    p = tr.positions @ r.T + np.asarray(shift, float)
    p += np.random.default_rng(seed).normal(0, noise, p.shape) * [1, 1, 0]
    return Trajectory.from_xy_yaw(tr.timestamps, p[:, 0], p[:, 1], tr.yaw + yaw)


# ---------------------------------------------------------------- Trajectory
def test_trajectory_normalises_quaternions_and_is_read_only():
    tr = Trajectory([0.0, 1.0], np.zeros((2, 3)), [[2.0, 0, 0, 0], [0, 0, 0, 3.0]])
    assert np.allclose(np.linalg.norm(tr.orientations, axis=1), 1.0)
    with pytest.raises(ValueError):
        tr.positions[0, 0] = 1.0
    assert len(tr) == 2 and tr.is_planar


def test_trajectory_rejects_bad_input_naming_the_source():
    with pytest.raises(TrajectoryError, match="f.txt: no poses"):
        Trajectory(np.empty(0), np.empty((0, 3)), source="f.txt")
    with pytest.raises(TrajectoryError, match="NaN or infinite position in pose 2"):
        Trajectory([0, 1.0], [[0, 0, 0], [np.nan, 0, 0]])
    with pytest.raises(TrajectoryError, match="zero quaternion in pose 1"):
        Trajectory([0.0], [[0, 0, 0]], [[0, 0, 0, 0]])
    with pytest.raises(TrajectoryError, match="non-monotonic timestamps: pose 3"):
        Trajectory([0, 1, 0.5], np.zeros((3, 3)))
    with pytest.raises(TrajectoryError, match="shape"):
        Trajectory([0, 1.0], np.zeros((3, 3)))


def test_quaternion_matrix_round_trip():
    rng = np.random.default_rng(3)
    q = rng.normal(size=(500, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    q *= np.sign(q[:, :1])
    back = matrix_to_quat(quat_to_matrix(q))
    assert np.allclose(back, q, atol=1e-12)
    r = quat_to_matrix(q)
    assert np.allclose(np.einsum("nij,nkj->nik", r, r), np.eye(3), atol=1e-12)


# ---------------------------------------------------------------- readers
def test_tum_round_trip_with_comments_and_irregular_spacing(tmp_path):
    tr = _planar(50)
    p = tr.write_tum(tmp_path / "a.txt")
    back = load_trajectory(p)
    assert back.meta["format"] == "tum"
    assert np.array_equal(back.timestamps, tr.timestamps)
    assert np.array_equal(back.positions, tr.positions)
    assert np.allclose(back.orientations, tr.orientations, atol=1e-15)
    # tabs, double spaces, trailing blanks and comments go through the slower parser
    lines = p.read_text().splitlines()
    messy = ["# header", *(ln.replace(" ", "  ", 2) + " \t" for ln in lines[:10]), "# end"]
    (tmp_path / "b.txt").write_text("\n".join(messy) + "\n")
    b = load_trajectory(tmp_path / "b.txt")
    assert np.array_equal(b.positions, tr.positions[:10])


@pytest.mark.parametrize("variant", ["crlf", "cr", "bom", "blank_lines", "tabs",
                                     "comment_between", "comment_after", "single_pose"])
def test_tum_text_variants_read_the_same_numbers(tmp_path, variant):
    tr = _planar(6)
    lines = tr.write_tum(tmp_path / "ref.txt").read_text().splitlines()
    if variant == "single_pose":
        lines = lines[:1]
    text = {
        "crlf": "\r\n".join(lines) + "\r\n",
        "cr": "\r".join(lines) + "\r",
        "bom": "\ufeff" + "\n".join(lines) + "\n",
        "blank_lines": "\n\n" + "\n\n".join(lines) + "\n\n  \n",
        "tabs": "\n".join(ln.replace(" ", "\t") for ln in lines) + "\n",
        "comment_between": "\n".join(lines[:3] + ["# restart?"] + lines[3:]) + "\n",
        "comment_after": "\n".join(ln + " # note" for ln in lines) + "\n",
        "single_pose": lines[0] + "\n",
    }[variant]
    p = tmp_path / "v.txt"
    p.write_bytes(text.encode())
    back = load_trajectory(p)
    assert back.meta["format"] == "tum"
    n = len(lines)
    assert np.array_equal(back.timestamps, tr.timestamps[:n])
    assert np.array_equal(back.positions, tr.positions[:n])


def test_kitti_matched_by_index(tmp_path):
    tr = _planar(30)
    m = tr.matrices()[:, :3, :].reshape(-1, 12)
    np.savetxt(tmp_path / "gt.txt", m, fmt="%.17g")
    k = load_trajectory(tmp_path / "gt.txt")
    assert k.meta["format"] == "kitti"
    assert k.timestamps.tolist() == list(range(30))
    assert np.allclose(k.rotations, tr.rotations, atol=1e-14)
    assert np.array_equal(k.positions, tr.positions)
    assert ate(k, k, align="none").n == 30
    # six printed digits (KITTI's own files) still read; garbage rotations do not
    np.savetxt(tmp_path / "six.txt", m, fmt="%.6e")
    assert np.allclose(load_trajectory(tmp_path / "six.txt").positions, tr.positions, atol=1e-5)
    for name, block in (("zero", np.zeros(9)), ("scaled", 2 * np.eye(3).ravel()),
                        ("mirror", np.diag([1.0, 1.0, -1.0]).ravel())):
        bad = m.copy()
        bad[4, [0, 1, 2, 4, 5, 6, 8, 9, 10]] = block
        np.savetxt(tmp_path / f"{name}.txt", bad, fmt="%.17g")
        with pytest.raises(TrajectoryError, match=rf"{name}.txt: pose 5 is not a rigid"):
            load_trajectory(tmp_path / f"{name}.txt")


def test_euroc_csv(tmp_path):
    p = tmp_path / "data.csv"
    p.write_text(
        "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], "
        "q_RS_y [], q_RS_z [], v_RS_R_x [m s^-1]\n"
        "1403636579758555392,4.688319,-1.786938,0.783338,0.534108,-0.153029,-0.827383,"
        "-0.082152,-0.027876\n"
        "1403636579763555584,4.688177,-1.786770,0.787350,0.534640,-0.152990,-0.826976,"
        "-0.082863,-0.029272\n"
    )
    tr = load_trajectory(p)
    assert tr.meta["format"] == "euroc"
    assert tr.timestamps[0] == 1403636579758555392 / 1e9
    assert tr.positions[1].tolist() == [4.688177, -1.786770, 0.787350]
    q = np.array([0.534108, -0.153029, -0.827383, -0.082152])
    assert np.allclose(tr.orientations[0], q / np.linalg.norm(q))


def test_generic_tables(tmp_path):
    p = tmp_path / "log.txt"
    p.write_text("time x y theta\n0 0 0 0\n1 1 0 1.5707963267948966\n")
    tr = load_trajectory(p)  # header names recognised
    assert tr.meta["format"] == "csv"
    assert np.isclose(tr.yaw[1], np.pi / 2)
    q = tmp_path / "plain.txt"
    q.write_text("0 5 0 0 9\n1 6 1 0.5 9\n")
    tr = load_trajectory(q, columns="t,x,y,yaw,_")
    assert tr.positions[:, 0].tolist() == [5.0, 6.0]
    assert np.isclose(tr.yaw[1], 0.5)
    c = tmp_path / "quat.csv"
    c.write_text("stamp;px;py;pz;w;i;j;k\n0;1;2;3;0;0;0;1\n")
    tr = load_trajectory(c, columns={"t": "stamp", "x": "px", "y": "py", "z": "pz",
                                     "qw": "w", "qx": "i", "qy": "j", "qz": "k"})
    assert tr.positions.tolist() == [[1.0, 2.0, 3.0]]
    assert tr.orientations.tolist() == [[0.0, 0.0, 0.0, 1.0]]
    n = tmp_path / "xy.csv"
    n.write_text("x,y\n1,2\n3,4\n")
    assert load_trajectory(n, by_index=True).timestamps.tolist() == [0.0, 1.0]  # row index
    h = tmp_path / "commented.txt"
    h.write_text("# recorded by me\n\n# time x y yaw\n0 1 2 0\n# pause\n1 3 4 0.25\n")
    tr = load_trajectory(h)  # the header is the comment line above the data
    assert tr.positions[:, :2].tolist() == [[1.0, 2.0], [3.0, 4.0]]
    assert np.isclose(tr.yaw[1], 0.25)
    h.write_text("# notes\n\ntime x y\n\n0 1 2\n1 3 4\n")
    assert load_trajectory(h, columns={"t": "time", "x": "x", "y": "y"}).timestamps.tolist() == [
        0.0, 1.0]


def test_parse_columns():
    assert parse_columns("t=0, x=slam_x ,y=2") == {"t": 0, "x": "slam_x", "y": 2}
    assert parse_columns("t,x,y,qx,qy,qz,qw") == {
        "t": 0, "x": 1, "y": 2, "qx": 3, "qy": 4, "qz": 5, "qw": 6}
    for bad in ("t,x", "t=a,x", "t,x,y,speed", "t,x,y,qx", "t,x,y,yaw,qw,qx,qy,qz"):
        with pytest.raises(TrajectoryError):
            parse_columns(bad)


def test_slam_comparison_logs_load_with_one_line_mapping():
    logs = sorted(TRAJ.glob("*/*_pose_log.csv"))
    assert len(logs) == 15
    for log in logs:
        if log.name == "cartographer_pose_log.csv" and log.parent.name == "abstract":
            continue
        if log.name == "rgbd_rtabmap_pose_log.csv" and log.parent.name == "warehouse":
            continue
        est = load_trajectory(log, columns={"t": "timestamp_sec", "x": "slam_x", "y": "slam_y"})
        gt = load_trajectory(log, columns=GT)
        assert len(est) == len(gt) == len(log.read_text().splitlines()) - 1
        assert est.is_planar
    # The MANIFEST's sanity value: gmapping/abstract, no alignment, 0.0752.
    log = TRAJ / "abstract" / "gmapping_pose_log.csv"
    r = ate(load_trajectory(log, columns=GT), load_trajectory(log, columns=SLAM), align="none")
    assert round(r.rmse, 4) == 0.0752 and r.n == 80


def test_restarted_log_errors_then_loads_with_unsorted_last():
    log = TRAJ / "abstract" / "cartographer_pose_log.csv"
    with pytest.raises(TrajectoryError, match=r"cartographer_pose_log\.csv: non-monotonic"):
        load_trajectory(log, columns=SLAM)
    tr = load_trajectory(log, columns=SLAM, unsorted="last")
    assert len(tr) == 80 and tr.timestamps[0] == 40.0
    assert np.all(np.diff(tr.timestamps) > 0)
    srt = load_trajectory(log, columns=SLAM, unsorted="sort")
    assert len(srt) == 86 and np.all(np.diff(srt.timestamps) >= 0)


@pytest.mark.parametrize(
    "text, reason",
    [
        ("", "empty file"),
        ("# only a comment\n", "empty file"),
        ("0 1 2 3 0 0 0 1\n1 1 2 nan 0 0 0 1\n", "NaN"),
        ("0 1 2 3 0 0 0 1\n1 1 2 3 0 0 0\n", "missing or NaN value in data row 2"),
        ("0 1 2 3 0 0 0 1\n1 1 a 3 0 0 0 1\n", "not a numeric table"),
        ("0 1 2 3 0\n", "cannot tell the format"),
        ("1 0 0 0 0 0 0 1\n0 0 0 0 0 0 0 1\n", "non-monotonic timestamps"),
        ("0 1 2 3 0 0 0 0\n", "zero quaternion"),
    ],
)
def test_bad_files_raise_naming_the_file(tmp_path, text, reason):
    p = tmp_path / "bad.txt"
    p.write_text(text)
    with pytest.raises(TrajectoryError, match=reason) as exc:
        load_trajectory(p)
    assert str(p) in str(exc.value)


def test_other_load_errors(tmp_path):
    with pytest.raises(TrajectoryError, match="no such file"):
        load_trajectory(tmp_path / "missing.txt")
    with pytest.raises(TrajectoryError, match="unknown trajectory format"):
        load_trajectory(tmp_path, format="g2o")
    p = tmp_path / "log.csv"
    p.write_text("a,b\n1,2\n")
    with pytest.raises(TrajectoryError, match="cannot tell the x and y columns"):
        load_trajectory(p)
    with pytest.raises(TrajectoryError, match="no column 'timestamp_sec' for 't'"):
        load_trajectory(p, columns=SLAM)
    bag = tmp_path / "broken.bag"
    bag.write_bytes(b"not a bag at all")
    with pytest.raises(SlamqError) as exc:
        load_trajectory(bag)
    assert "broken.bag" in str(exc.value)


# ---------------------------------------------------------------- association
def test_association_nearest_within_max_dt_with_offset():
    gt = Trajectory(np.arange(10.0), np.zeros((10, 3)))
    est = Trajectory(np.array([0.004, 2.5, 3.006, 9.02]) + 100.0, np.zeros((4, 3)))
    with pytest.raises(TrajectoryError, match="no pose is within max_dt"):
        associate(gt, est)
    gi, ei = associate(gt, est, offset=-100.0)
    assert gi.tolist() == [0, 3] and ei.tolist() == [0, 2]
    gi, ei = associate(gt, est, max_dt=0.5, offset=-100.0)
    assert gi.tolist() == [0, 2, 3, 9] and ei.tolist() == [0, 1, 2, 3]  # tie -> earlier


# ---------------------------------------------------------------- ATE / SE(2)
def test_se2_recovers_a_known_planar_motion_with_noise():
    gt = _planar(400)
    yaw, shift = 0.8, (12.0, -3.5, 0.0)
    est = _moved(gt, yaw, shift, noise=0.01)
    r = ate(gt, est)  # se2 by default
    a = r.alignment
    assert r.align == "se2"
    assert abs(a.yaw + yaw) < 2e-3  # the inverse motion
    back = np.array([[np.cos(-yaw), -np.sin(-yaw)], [np.sin(-yaw), np.cos(-yaw)]]) @ shift[:2]
    assert np.allclose(a.translation[:2], -back, atol=0.01)
    assert a.translation[2] == 0.0 and np.allclose(a.rotation[2], [0, 0, 1])
    assert 0.005 < r.rmse < 0.02  # the noise is left, not the motion
    assert ate(gt, est, align="none").rmse > 5


def test_se2_equals_se3_on_planar_data():
    gt = _planar(300, seed=5)
    est = _moved(gt, -2.0, (1.0, 2.0, 0.0), noise=0.05, seed=6)
    a, b = ate(gt, est, align="se2"), ate(gt, est, align="se3")
    assert abs(a.rmse - b.rmse) < 1e-9
    assert np.allclose(a.errors, b.errors, atol=1e-9)
    assert np.allclose(a.alignment.matrix(), b.alignment.matrix(), atol=1e-9)


def test_se2_ignores_height_differences_in_the_fit():
    gt = _planar(100)
    est = _moved(gt, 0.3, (1.0, 1.0, 0.0))
    lifted = Trajectory(est.timestamps, est.positions + [0, 0, 2.0], est.orientations)
    r = ate(gt, lifted, align="se2")
    assert np.allclose(r.errors, 2.0)  # z is not aligned by se2


def test_origin_alignment_makes_first_poses_equal():
    gt = _planar(50)
    est = _moved(gt, 1.0, (5.0, 5.0, 0.0))
    r = ate(gt, est, align="origin")
    assert r.errors[0] < 1e-12 and r.rmse < 1e-9


def test_sim3_recovers_scale():
    gt = _planar(100)
    est = Trajectory(gt.timestamps, gt.positions * 0.5, gt.orientations)
    r = ate(gt, est, align="sim3")
    assert abs(r.scale - 2.0) < 1e-12 and r.rmse < 1e-12


@pytest.mark.parametrize(
    "align, positions, reason",
    [
        ("se2", np.zeros((5, 3)), "se2 needs at least 2 distinct"),
        ("se3", np.repeat([[0, 0, 0], [1, 0, 0]], 3, axis=0), "se3 needs at least 3 distinct"),
        ("sim3", np.zeros((5, 3)), "sim3 needs at least 3 distinct"),
        ("se3", np.outer(np.arange(5.0), [1.0, 0, 0]), "degenerate alignment"),
    ],
)
def test_degenerate_alignment(align, positions, reason):
    n = positions.shape[0]
    est = Trajectory(np.arange(n, dtype=float), positions, source="est.txt")
    gt = Trajectory(np.arange(n, dtype=float), np.random.default_rng(0).normal(size=(n, 3)))
    with pytest.raises(TrajectoryError, match=reason) as exc:
        ate(gt, est, align=align)
    assert "est.txt" in str(exc.value)


def test_ate_statistics_and_paths(tmp_path):
    gt = _planar(60)
    est = Trajectory(gt.timestamps, gt.positions + [0.3, 0.4, 0.0], gt.orientations)
    r = ate(gt, est, align="none")
    assert np.allclose(r.errors, 0.5) and r.n == 60
    assert abs(r.rmse - 0.5) < 1e-15 and r.sse == pytest.approx(60 * 0.25)
    d = r.to_dict()
    assert set(d) >= {"rmse", "mean", "median", "std", "min", "max", "sse", "n"}
    g, e = gt.write_tum(tmp_path / "g.txt"), est.write_tum(tmp_path / "e.txt")
    with pytest.warns(DeprecationWarning, match="read it with slamq.load_trajectory"):
        assert slamq.ate(g, e, align="none").rmse == pytest.approx(0.5, abs=1e-12)
    with pytest.raises(TrajectoryError, match="unknown alignment"):
        ate(gt, est, align="se4")


# ---------------------------------------------------------------- RPE
def test_rpe_frames_and_metres():
    t = np.arange(21.0)
    gt = Trajectory.from_xy_yaw(t, t, 0 * t)
    est = Trajectory.from_xy_yaw(t, 1.1 * t, 0 * t)
    r = rpe(gt, est, delta=5)
    assert r.n == 4 and np.allclose(r.errors, 0.5)
    m = rpe(gt, est, delta=2.0, unit="m")  # est travels 1.1 m per step: pairs 2 steps apart
    assert m.n == 10 and np.allclose(m.errors, 0.2)
    a = rpe(gt, Trajectory.from_xy_yaw(t, t, 0 * t, 0.01 * t), delta=1, relation="angle_deg")
    assert np.allclose(a.errors, np.rad2deg(0.01))
    with pytest.raises(TrajectoryError, match="no pose pair"):
        rpe(gt, est, delta=50)
    with pytest.raises(TrajectoryError, match="integer"):
        rpe(gt, est, delta=1.5)
    for bad in (float("inf"), float("nan")):  # were OverflowError / ValueError
        with pytest.raises(TrajectoryError, match="integer >= 1"):
            rpe(gt, est, delta=bad)
        with pytest.raises(TrajectoryError, match="number > 0"):
            rpe(gt, est, delta=bad, unit="m")


def test_rpe_metre_pairs_on_a_long_trajectory_are_fast_and_sequential():
    """Pairs by path length on 200,000 poses (a pair every ~2 steps): evo's sequential
    rule (the sum restarts at 0 at every pair), in well under a second."""
    import time

    n = 200_000
    step = np.random.default_rng(3).uniform(0.0, 0.02, n - 1)
    x = np.concatenate([[0.0], np.cumsum(step)])
    tr = Trajectory.from_xy_yaw(np.arange(n) * 0.01, x, 0 * x)
    t0 = time.perf_counter()
    r = rpe(tr, tr, delta=0.015, unit="m")
    assert time.perf_counter() - t0 < 3.0
    ids, travelled = [0], 0.0
    for k, d in enumerate(np.abs(np.diff(x)).tolist(), 1):
        travelled += d
        if travelled >= 0.015:
            ids.append(k)
            travelled = 0.0
    assert r.n == len(ids) - 1 and r.n > n // 3
    assert np.array_equal(r.timestamps, tr.timestamps[ids[1:]])


def test_rpe_is_invariant_to_rigid_alignment():
    gt = _planar(120)
    est = _moved(gt, 0.4, (3, 1, 0), noise=0.02)
    base = rpe(gt, est, delta=3)
    for align in ("se2", "se3", "origin"):
        assert np.allclose(rpe(gt, est, delta=3, align=align).errors, base.errors, atol=1e-12)


# ---------------------------------------------------------------- runs
def test_ate_runs_population_and_sample_std():
    gt = _planar(80)
    offsets = [0.1, 0.2, 0.6]
    ests = [Trajectory(gt.timestamps, gt.positions + [o, 0, 0], gt.orientations)
            for o in offsets]
    r = ate_runs(gt, ests, align="none")
    assert np.allclose(r.rmse, offsets)
    assert r.mean == pytest.approx(0.3)
    assert r.std == pytest.approx(np.std(offsets))
    assert r.std_sample == pytest.approx(np.std(offsets, ddof=1))
    assert r.n_runs == 3
    assert str(r) == f"0.300 \u00b1 {np.std(offsets, ddof=1):.3f} m (3 runs, sample std)"
    one = ate_runs(gt, ests[:1], align="none")
    assert np.isnan(one.std_sample) and one.std == 0.0
    assert one.to_dict()["rmse_std_sample"] is None


def test_public_names():
    # the public functions take paths too (deprecated) and call these metrics
    assert slamq.ate is slamq.api.ate and slamq.rpe is slamq.api.rpe
    assert slamq.ate_runs is slamq.api.ate_runs
    assert slamq.api.ate_of is ate and slamq.api.rpe_of is rpe
    assert slamq.api.ate_runs_of is ate_runs
    assert slamq.Trajectory is Trajectory and slamq.load_trajectory is load_trajectory


# ---------------------------------------------------------------- CLI
def test_cli_ate_on_the_pose_logs(tmp_path, capsys):
    logs = [str(TRAJ / "office" / f"{a}_pose_log.csv") for a in ("gmapping", "slam_toolbox")]
    out = tmp_path / "ate.json"
    rc = main(["ate", logs[0], *logs, "--gt-columns", "t=timestamp_sec,x=gt_x,y=gt_y",
               "--columns", "t=timestamp_sec,x=slam_x,y=slam_y", "-a", "none",
               "--json", str(out), "--runs"])
    assert rc == 0
    text = capsys.readouterr().out
    assert "RMSE over 2 runs (align none)" in text and "0.0948" in text
    doc = json.loads(out.read_text())
    assert [round(r["rmse"], 4) for r in doc["results"]] == [0.0948, 0.0425]
    assert doc["summary"]["runs"] == 2 and doc["failed"] == []


def test_cli_runs_std_is_the_one_slamq_summary_prints(tmp_path, capsys):
    """`slamq ate GT r1 r2 r3` and `slamq summary` give the same "mean +- std" (sample)."""
    from slamq.results.summary import summarize

    gt = _planar(80)
    g = gt.write_tum(tmp_path / "gt.txt")
    runs = [Trajectory(gt.timestamps, gt.positions + [o, 0, 0], gt.orientations)
            .write_tum(tmp_path / f"run{i}.txt") for i, o in enumerate((0.1, 0.2, 0.6))]
    out = tmp_path / "ate.json"
    assert main(["ate", str(g), *map(str, runs), "-a", "none", "--json", str(out),
                 "--runs"]) == 0
    text = capsys.readouterr().out
    doc = json.loads(out.read_text())
    rmse = [r["rmse"] for r in doc["results"]]
    s = summarize([{"algorithm": "a", "sequence": "s", "run": str(i), "ate_rmse": v,
                    "error": None} for i, v in enumerate(rmse)])
    std = float(s.loc[0, "ate_rmse_std"])
    assert std == pytest.approx(np.std(rmse, ddof=1), rel=1e-12)
    assert f"\u00b1 {std:.6f} m (sample std" in text
    assert doc["summary"]["rmse_std_sample"] == pytest.approx(std, rel=1e-12)
    assert doc["summary"]["rmse_std"] == pytest.approx(np.std(rmse), rel=1e-12)


def test_cli_errors_exit_2_with_one_line(tmp_path, capsys):
    gt = _planar(40).write_tum(tmp_path / "gt.txt")
    empty = tmp_path / "empty.txt"
    empty.write_text("")
    rc = main(["ate", str(gt), str(empty)])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "empty.txt" in err[0] and "empty file" in err[0]
    far = Trajectory(np.arange(40) * 0.1 + 1000, np.ones((40, 3))).write_tum(tmp_path / "far.txt")
    rc = main(["rpe", str(gt), str(far)])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "far.txt" in err[0] and "max_dt" in err[0]
    rc = main(["ate", str(tmp_path / "nope.txt"), str(gt)])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "nope.txt" in err[0]


def test_cli_rpe(tmp_path, capsys):
    gt = _planar(60)
    g = gt.write_tum(tmp_path / "gt.txt")
    e = _moved(gt, 0.2, (1, 1, 0), noise=0.01).write_tum(tmp_path / "est.txt")
    rc = main(["rpe", str(g), str(e), "--delta", "0.5", "--unit", "m", "--json",
               str(tmp_path / "r.json")])
    assert rc == 0
    doc = json.loads((tmp_path / "r.json").read_text())
    ref = rpe(load_trajectory(g), load_trajectory(e), delta=0.5, unit="m")
    assert doc["results"][0]["rmse"] == pytest.approx(ref.rmse, abs=1e-15)
    assert "RPE" in capsys.readouterr().out


# ---------------------------------------------------------------- ROS bags
@pytest.mark.parametrize("fmt", ["ros1", "mcap"])
def test_bag_trajectory_through_load_trajectory(tmp_path, fmt, capsys):
    _bagdata = pytest.importorskip("_bagdata")
    gt = _planar(30)
    est = _moved(gt, 0.5, (2.0, -1.0, 0.0), noise=0.01)
    path = _bagdata.bag_path(tmp_path, fmt)
    with _bagdata.BagWriter(path, fmt) as w:
        for t, p, q in zip(est.timestamps + 100.0, est.positions, est.orientations):
            msg = w.T["geometry_msgs/msg/PoseStamped"](header=w.header(t), pose=w.pose(p, q))
            w.write("/slam_pose", "geometry_msgs/msg/PoseStamped", msg)
    gt_file = Trajectory(gt.timestamps + 100.0, gt.positions, gt.orientations).write_tum(
        tmp_path / "gt.txt")
    from_bag = load_trajectory(path, topic="/slam_pose")
    assert len(from_bag) == 30
    assert np.allclose(from_bag.positions, est.positions, atol=1e-12)
    ref = ate(load_trajectory(gt_file), Trajectory(est.timestamps + 100.0, est.positions,
                                                   est.orientations))
    assert ate(load_trajectory(gt_file), load_trajectory(path)).rmse == pytest.approx(
        ref.rmse, abs=1e-9)
    rc = main(["ate", str(gt_file), str(path), "--topic", "/slam_pose"])
    assert rc == 0 and f"{ref.rmse:.6f}" in capsys.readouterr().out


@pytest.mark.parametrize(
    "text, reason",
    [
        ("0 1 2 0 0 0 0 1\n0.1 nan 2 0 0 0 0 1\n", "NaN"),
        ("0.2 1 2 0 0 0 0 1\n0.1 1 2 0 0 0 0 1\n", "non-monotonic timestamps"),
        ("0 1 2 0 0 0 0 1\n0.1 1 2 0 0 0 0 1\n0.2 1 2 0 0 0 0 1\n", "degenerate alignment"),
    ],
)
def test_cli_bad_estimate_one_line_exit_2(tmp_path, capsys, text, reason):
    gt = _planar(40).write_tum(tmp_path / "gt.txt")
    bad = tmp_path / "est.txt"
    bad.write_text(text)
    rc = main(["ate", str(gt), str(bad), "--align", "se2"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1
    assert str(bad) in err[0] and reason in err[0]


def test_cli_ate_reads_a_paired_pose_log_as_batch_does(capsys):
    """`slamq ate LOG.csv`: a slam_comparison_tools log holds estimate and ground truth;
    the same column detection as `slamq batch`, so the same number."""
    from slamq.sources.trajectories import load_pair

    log = TRAJ / "office" / "gmapping_pose_log.csv"
    est, gt = load_pair(log, log)
    expected = ate(gt, est)
    assert main(["ate", str(log)]) == 0
    out = capsys.readouterr().out
    assert "(align se2)" in out and f"{expected.rmse:.6f}" in out


def test_tables_without_time_are_refused_unless_by_index(tmp_path, capsys):
    xy = tmp_path / "xy.csv"
    xy.write_text("x,y\n0,0\n1,0\n2,0\n")
    gt = tmp_path / "gt.csv"
    gt.write_text("x,y\n0,0\n1,0.1\n2,0\n")
    with pytest.raises(TrajectoryError, match="no time column.*by_index=True"):
        load_trajectory(xy)
    assert main(["ate", str(gt), str(xy)]) == 2
    assert "--by-index" in capsys.readouterr().err
    assert main(["ate", str(gt), str(xy), "--by-index", "-a", "none"]) == 0
    assert "0.057735" in capsys.readouterr().out  # sqrt(0.01 / 3)
    # no orientation column: an angle RPE would be all zeros, so it is refused
    assert main(["rpe", str(gt), str(xy), "--by-index", "--relation", "angle_deg"]) == 2
    assert "no orientation column" in capsys.readouterr().err


def test_cli_ate_several_estimates_is_one_row_each_unless_runs(tmp_path, capsys):
    gt = _planar(40)
    g = gt.write_tum(tmp_path / "gt.txt")
    a = Trajectory(gt.timestamps, gt.positions + [0.1, 0, 0], gt.orientations)
    b = Trajectory(gt.timestamps, gt.positions + [0.3, 0, 0], gt.orientations)
    files = [str(a.write_tum(tmp_path / "a.txt")), str(b.write_tum(tmp_path / "b.txt"))]
    assert main(["ate", str(g), *files, "-a", "none"]) == 0
    out = capsys.readouterr().out
    assert "RMSE over" not in out and "one row per estimate; --runs" in out
    assert main(["ate", str(g), *files, "-a", "none", "--runs"]) == 0
    assert "RMSE over 2 runs (align none): 0.200000" in capsys.readouterr().out


def test_the_core_table_reader_equals_python_float_and_leaves_irregular_files_to_pandas(
        tmp_path) -> None:
    """slamq._core.read_table (the fast path of every text trajectory) parses each number as
    Python's float does, bit for bit, and returns None on anything irregular, so that the
    general reader still names the file and the row."""
    from slamq import _core

    rng = np.random.default_rng(11)
    tokens = [[repr(float(x)) for x in row] for row in rng.normal(size=(500, 8)) * 10.0 ** (
        rng.integers(-12, 12, size=(500, 8)))]
    tokens[3][2] = "1600000000.123456789"
    tokens[4][5] = "-0.000000000"
    tokens[5][1] = "12345678901234567890123e-3"
    text = "# t x y z qx qy qz qw\n" + "\n".join("\t ".join(r) + "  # c" * (i % 2)
                                               for i, r in enumerate(tokens)) + "\n\n"
    p = tmp_path / "t.txt"
    p.write_text(text)
    got = _core.read_table(p, " ", 0)
    want = np.array([[float(x) for x in r] for r in tokens])
    assert got is not None and got.shape == (500, 8)
    assert np.array_equal(got.view(np.int64), want.view(np.int64))
    for bad in ("1 2 3\n4 5\n", "1 2 nan\n", "1 2 x\n", "1,2\n"):
        p.write_text(bad)
        assert _core.read_table(p, " ", 0) is None, bad
    p.write_text("0 1 2 0 0 0 0 1\n1 1 2 0 0 0 1\n")
    with pytest.raises(slamq.TrajectoryError, match=r"t\.txt.*row 2"):
        slamq.load_trajectory(p)
    assert _core.read_table(tmp_path / "absent.txt", " ", 0) is None


def test_distinct_points_are_found_beyond_the_first_poses() -> None:
    """The alignment's check for enough distinct points looks at the first 4096 poses
    first; a long trajectory whose first poses all coincide is still judged on all."""
    from slamq.metrics.align import _distinct_at_least

    p = np.zeros((10_000, 3))
    assert not _distinct_at_least(p, 2)
    p[9_000] = [1.0, 0.0, 0.0]
    assert _distinct_at_least(p, 2) and not _distinct_at_least(p, 3)
    p[9_500] = [0.0, 1.0, 0.0]
    assert _distinct_at_least(p, 3)
    p[:3] = [[0.0, 0, 0], [1, 0, 0], [2, 0, 0]]
    assert _distinct_at_least(p, 3)
