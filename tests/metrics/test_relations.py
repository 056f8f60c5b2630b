"""The relations error (docs/spec.md 6a): definitions, a plain numpy twin, bad files, the
real relations files of ../shared/data/datasets2d when present."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from conftest import SHARED_DATA
from hypothesis import given, settings
from hypothesis import strategies as st

import slamq
from slamq.cli import main
from slamq.errors import TrajectoryError
from slamq.metrics.relations import invert_motion, relations
from slamq.models import Trajectory
from slamq.models.relations import Relations
from slamq.sources.relations import read_relations

DATASETS = SHARED_DATA / "datasets2d"


# ------------------------------------------------------------------ the plain twin
def _mat(x: float, y: float, th: float) -> np.ndarray:
    c, s = math.cos(th), math.sin(th)
    return np.array([[c, -s, x], [s, c, y], [0.0, 0.0, 1.0]])


def _twin(tr: Trajectory, rel: Relations) -> tuple[np.ndarray, np.ndarray]:
    """Per relation, one at a time, with 3x3 homogeneous matrices: the pose at a stamp is
    the pose with exactly that timestamp; e = inv(D*) @ inv(X1) @ X2."""
    where = {float(t): i for i, t in enumerate(tr.timestamps)}
    yaw = tr.yaw
    et, er = [], []
    for a, b, m in zip(rel.t1, rel.t2, rel.motion):
        i, j = where[float(a)], where[float(b)]
        x1 = _mat(tr.positions[i, 0], tr.positions[i, 1], yaw[i])
        x2 = _mat(tr.positions[j, 0], tr.positions[j, 1], yaw[j])
        e = np.linalg.inv(_mat(*m)) @ np.linalg.inv(x1) @ x2
        et.append(math.hypot(e[0, 2], e[1, 2]))
        er.append(math.degrees(abs(math.atan2(e[1, 0], e[0, 0]))))
    return np.array(et), np.array(er)


def _true_relations(tr: Trajectory, i: np.ndarray, j: np.ndarray) -> Relations:
    """The exact motions between poses i and j of tr."""
    yaw = tr.yaw
    p = tr.positions
    c, s = np.cos(yaw[i]), np.sin(yaw[i])
    dx, dy = p[j, 0] - p[i, 0], p[j, 1] - p[i, 1]
    m = np.column_stack([c * dx + s * dy, -s * dx + c * dy, yaw[j] - yaw[i]])
    return Relations(tr.timestamps[i], tr.timestamps[j], m)


def _walk(n: int, seed: int) -> Trajectory:
    rng = np.random.default_rng(seed)
    t = np.cumsum(rng.uniform(0.05, 0.3, n))
    yaw = np.cumsum(rng.normal(0, 0.3, n))
    step = rng.uniform(0, 0.5, n)
    x = np.cumsum(step * np.cos(yaw))
    y = np.cumsum(step * np.sin(yaw))
    return Trajectory.from_xy_yaw(t, x, y, yaw)


def _moved(tr: Trajectory, dx: float, dy: float, dth: float) -> Trajectory:
    c, s = math.cos(dth), math.sin(dth)
    p = tr.positions
    return Trajectory.from_xy_yaw(tr.timestamps, c * p[:, 0] - s * p[:, 1] + dx,
                                  s * p[:, 0] + c * p[:, 1] + dy, tr.yaw + dth)


# ------------------------------------------------------------------ definitions
def test_a_perfect_trajectory_has_zero_error() -> None:
    tr = _walk(300, 1)
    rng = np.random.default_rng(2)
    i, j = rng.integers(0, 300, 500), rng.integers(0, 300, 500)
    r = relations(tr, _true_relations(tr, i, j))
    assert r.n == 500 and r.n_unplaced == 0
    assert r.trans_max < 1e-9 and r.rot_max < 1e-7
    assert r.trans_sq_mean < 1e-18


@given(dx=st.floats(-1e3, 1e3), dy=st.floats(-1e3, 1e3), dth=st.floats(-10, 10),
       seed=st.integers(0, 10_000))
@settings(max_examples=40, deadline=None)
def test_a_rigid_motion_of_the_whole_trajectory_changes_nothing(
        dx: float, dy: float, dth: float, seed: int) -> None:
    tr = _walk(60, seed)
    rng = np.random.default_rng(seed)
    i, j = rng.integers(0, 60, 80), rng.integers(0, 60, 80)
    m = _true_relations(tr, i, j).motion + rng.normal(0, 0.1, (80, 3))   # a wrong estimate
    rel = Relations(tr.timestamps[i], tr.timestamps[j], m)
    a, b = relations(tr, rel), relations(_moved(tr, dx, dy, dth), rel)
    np.testing.assert_allclose(b.trans_errors, a.trans_errors, atol=1e-9)
    np.testing.assert_allclose(b.rot_errors, a.rot_errors, atol=1e-7)
    perfect = _true_relations(tr, i, j)
    assert relations(_moved(tr, dx, dy, dth), perfect).trans_max < 1e-8


def _two(p0: tuple, p1: tuple) -> Trajectory:
    return Trajectory.from_xy_yaw([0.0, 1.0], [p0[0], p1[0]], [p0[1], p1[1]], [p0[2], p1[2]])


def test_hand_computed_translation_rotation_and_frame() -> None:
    # 1 m ahead, the relation says 1.1 m: 0.1 m, no rotation
    r = relations(_two((0, 0, 0), (1, 0, 0)), Relations([0.0], [1.0], [[1.1, 0, 0]]))
    assert r.trans_abs_mean == pytest.approx(0.1) and r.rot_abs_mean == 0.0
    # facing +y, the robot moves 1 m along y: 1 m ahead in its own frame
    tr = _two((0, 0, math.pi / 2), (0, 1, math.pi / 2))
    r = relations(tr, Relations([0.0], [1.0], [[1.0, 0, 0]]))
    assert r.trans_max < 1e-12 and r.rot_max < 1e-12
    # the relation says 1 m to the left instead: sqrt(2) m
    r = relations(tr, Relations([0.0], [1.0], [[0.0, 1.0, 0]]))
    assert r.trans_abs_mean == pytest.approx(math.sqrt(2))
    # the relation turns by 0.1 rad on the way: 0.1 rad, and the translation of
    # e = D*^-1 D is R(-0.1) (t_D - t*) = 0
    r = relations(tr, Relations([0.0], [1.0], [[1.0, 0, 0.1]]))
    assert r.rot_abs_mean == pytest.approx(math.degrees(0.1))
    assert r.rot_sq_mean == pytest.approx(math.degrees(0.1) ** 2)
    assert r.trans_max < 1e-12
    # e's translation is expressed in the relation's end frame: D* = (1, 0, pi/2),
    # D = (2, 0, pi/2): t_e = R(-pi/2) (1, 0) = (0, -1), norm 1
    r = relations(_two((0, 0, 0), (2, 0, math.pi / 2)),
                  Relations([0.0], [1.0], [[1.0, 0, math.pi / 2]]))
    assert r.trans_abs_mean == pytest.approx(1.0) and r.rot_max < 1e-12


def test_angles_wrap_across_pi() -> None:
    # heading 3.1 -> -3.1 is a turn of 2 pi - 6.2 = +0.0832 rad, not -6.2
    r = relations(_two((0, 0, 3.1), (0, 0, -3.1)), Relations([0.0], [1.0], [[0, 0, 0]]))
    assert r.rot_abs_mean == pytest.approx(math.degrees(2 * math.pi - 6.2))
    r = relations(_two((0, 0, 3.1), (0, 0, -3.1)),
                  Relations([0.0], [1.0], [[0, 0, 2 * math.pi - 6.2 + 4 * math.pi]]))
    assert r.rot_max < 1e-9


def test_statistics_are_the_published_ones() -> None:
    tr = Trajectory.from_xy_yaw([0.0, 1.0, 2.0], [0, 1, 2], [0, 0, 0], [0, 0, 0])
    rel = Relations([0.0, 1.0], [1.0, 2.0], [[1.1, 0, 0], [1.3, 0, math.radians(2.0)]])
    r = relations(tr, rel)
    assert r.trans_abs_mean == pytest.approx(0.2) and r.trans_abs_std == pytest.approx(0.1)
    assert r.trans_sq_mean == pytest.approx(0.05) and r.trans_sq_std == pytest.approx(0.04)
    assert r.trans_max == pytest.approx(0.3)
    assert r.rot_abs_mean == pytest.approx(1.0) and r.rot_abs_std == pytest.approx(1.0)
    assert r.rot_sq_mean == pytest.approx(2.0) and r.rot_sq_std == pytest.approx(2.0)
    assert r.rot_max == pytest.approx(2.0)
    d = r.to_dict(errors=True)
    assert d["n"] == 2 and d["rows"] == [0, 1] and len(d["trans_errors"]) == 2
    assert "0.2000 \u00b1 0.1000 m" in str(r)


def test_reversed_rows_are_inverted_and_duplicates_counted_as_given() -> None:
    tr = _walk(50, 5)
    rng = np.random.default_rng(6)
    i, j = np.arange(0, 40), np.arange(5, 45)
    good = _true_relations(tr, i, j)
    m = good.motion + rng.normal(0, 0.05, good.motion.shape)
    fwd = relations(tr, Relations(good.t1, good.t2, m))
    back = relations(tr, Relations(good.t2, good.t1, invert_motion(m)))
    assert back.n_reversed == 40 and fwd.n_reversed == 0
    np.testing.assert_allclose(back.trans_errors, fwd.trans_errors, atol=1e-12)
    np.testing.assert_allclose(back.rot_errors, fwd.rot_errors, atol=1e-9)
    # a row given twice counts twice
    k = np.r_[np.arange(40), 0, 0]
    dup = relations(tr, Relations(good.t1[k], good.t2[k], m[k]))
    assert dup.n == 42 and dup.n_duplicates == 2
    assert dup.trans_abs_mean == pytest.approx(fwd.trans_errors[k].mean())


@given(seed=st.integers(0, 100_000), n=st.integers(2, 80), k=st.integers(1, 120))
@settings(max_examples=60, deadline=None)
def test_equals_the_plain_matrix_twin(seed: int, n: int, k: int) -> None:
    rng = np.random.default_rng(seed)
    tr = Trajectory.from_xy_yaw(np.sort(rng.choice(10_000, n, replace=False)) * 0.1,
                                rng.normal(0, 50, n), rng.normal(0, 50, n),
                                rng.uniform(-4 * np.pi, 4 * np.pi, n))
    i, j = rng.integers(0, n, k), rng.integers(0, n, k)
    rel = Relations(tr.timestamps[i], tr.timestamps[j],
                    np.column_stack([rng.normal(0, 20, (k, 2)), rng.uniform(-7, 7, k)]))
    r = relations(tr, rel)
    et, er = _twin(tr, Relations(np.where(i <= j, rel.t1, rel.t2),
                                 np.where(i <= j, rel.t2, rel.t1),
                                 np.where((i <= j)[:, None], rel.motion,
                                          invert_motion(rel.motion))))
    np.testing.assert_allclose(r.trans_errors, et, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(r.rot_errors, er, atol=1e-7)
    assert r.trans_abs_mean == pytest.approx(et.mean(), rel=1e-9, abs=1e-12)
    assert r.rot_sq_std == pytest.approx((er ** 2).std(), rel=1e-6, abs=1e-9)


# ------------------------------------------------------------------ placing the stamps
def test_interpolation_places_stamps_between_poses() -> None:
    t = np.array([0.0, 1.0, 2.0, 10.0])
    tr = Trajectory.from_xy_yaw(t, t, 0 * t, 0.2 * t)   # x = t, yaw = 0.2 t
    rel = Relations([0.5, 0.0, 2.0], [1.5, 2.0, 6.0], [[1.0, 0, 0.2], [2.0, 0, 0.4],
                                                      [4.0, 0, 0.8]])
    exact = relations(tr, rel)
    assert exact.n == 1 and exact.n_unplaced == 2 and exact.placed.tolist() == [1]
    r = relations(tr, rel, interpolate=True, max_gap=1.0)
    assert relations(tr, rel, interpolate=True).n == 1       # default max_gap 0.5 s
    assert r.n == 2 and r.n_interpolated == 1 and r.placed.tolist() == [0, 1]
    # at 0.5 and 1.5: x 0.5, 1.5, yaw 0.1, 0.3: 1 m at heading 0.1 -> (cos, -sin)(0.1)
    d = np.array([math.cos(0.1), -math.sin(0.1)])
    assert r.trans_errors[0] == pytest.approx(np.linalg.norm(d - [1.0, 0.0]))
    assert r.rot_errors[0] == pytest.approx(0.0, abs=1e-9)
    wide = relations(tr, rel, interpolate=True, max_gap=8.0)   # 2 -> 10 is 8 s
    assert wide.n == 3 and wide.n_unplaced == 0


def test_interpolated_heading_takes_the_short_way_across_pi() -> None:
    tr = Trajectory.from_xy_yaw([0.0, 1.0, 2.0], [0, 0, 0], [0, 0, 0], [0.0, 3.1, -3.1])
    mid = 3.1 + (2 * math.pi - 6.2) / 2        # halfway from 3.1 to -3.1 the short way
    rel = Relations([0.0], [1.5], [[0.0, 0.0, mid]])
    assert relations(tr, rel, interpolate=True, max_gap=1.0).rot_max < 1e-9


def test_stamps_within_the_tolerance_match_and_nothing_placed_is_an_error() -> None:
    tr = Trajectory.from_xy_yaw([0.0, 1.0], [0.0, 1.0], [0, 0], [0, 0])
    rel = Relations([0.000004], [0.999996], [[1.0, 0, 0]])     # 5-decimal stamps
    assert relations(tr, rel).n == 1
    with pytest.raises(TrajectoryError, match="none of the 1 relations.*--interpolate"):
        relations(tr, rel, stamp_tol=1e-6)
    with pytest.raises(TrajectoryError, match="must be a Trajectory"):
        relations("est.txt", rel)  # type: ignore[arg-type]
    with pytest.raises(TrajectoryError, match="max_gap"):
        relations(tr, rel, interpolate=True, max_gap=-1)


# ------------------------------------------------------------------ files and the CLI
@pytest.mark.parametrize("text, reason", [
    ("", "no relations"),
    ("# only a comment\n\n", "no relations"),
    ("1 2 0.1 0 0 0 0\n", "line 1: 7 fields"),
    ("1 2 0.1 0 0 0 0 0\n1 2 x 0 0 0 0 0\n", "line 2: 'x' is not a number"),
    ("1 2 nan 0 0 0 0 0\n", "line 1: NaN"),
    ("1 2 0.1 0 0.5 0 0 0\n", "line 1: not a planar relation"),
])
def test_bad_relations_files_name_the_file_and_the_reason(
        tmp_path: Path, text: str, reason: str) -> None:
    p = tmp_path / "bad.relations"
    p.write_text(text)
    with pytest.raises(TrajectoryError, match=reason) as exc:
        read_relations(p)
    assert str(p) in str(exc.value)


def test_missing_file_and_gzip(tmp_path: Path) -> None:
    import gzip

    with pytest.raises(TrajectoryError, match="cannot read"):
        read_relations(tmp_path / "nope.relations")
    p = tmp_path / "r.relations.gz"
    with gzip.open(p, "wt") as f:
        f.write("1 2 0.5 0 0 0 0 0.25\n")
    assert read_relations(p).motion.tolist() == [[0.5, 0.0, 0.25]]


def _files(tmp_path: Path) -> tuple[Path, Path]:
    tr = _walk(40, 9)
    est = tr.write_tum(tmp_path / "est.txt")
    rel = _true_relations(tr, np.arange(0, 30), np.arange(3, 33))
    m = rel.motion.copy()
    m[0, 0] += 0.5
    rows = np.column_stack([rel.t1, rel.t2, m[:, 0], m[:, 1], 0 * m[:, :3], m[:, 2]])
    path = tmp_path / "gt.relations"
    np.savetxt(path, rows, fmt="%.9f")
    return est, path


def test_cli_prints_the_table_and_writes_json(tmp_path: Path, capsys) -> None:
    est, rel = _files(tmp_path)
    out = tmp_path / "r.json"
    rc = main(["relations", str(est), "--relations", str(rel), "--json", str(out),
               "--per-relation"])
    assert rc == 0
    text = capsys.readouterr().out
    assert "abs trans (m)" in text and "sq rot (deg^2)" in text and "est.txt" in text
    doc = json.loads(out.read_text())
    (res,) = doc["results"]
    assert res["n"] == 30 and res["trans_max"] == pytest.approx(0.5, abs=1e-6)
    assert len(res["trans_errors"]) == 30 and doc["failed"] == []
    api = slamq.relations(slamq.load_trajectory(est), slamq.load_relations(rel))
    assert api.trans_abs_mean == pytest.approx(res["trans_abs_mean"])


def test_cli_bad_input_exits_2_naming_the_file(tmp_path: Path, capsys) -> None:
    est, rel = _files(tmp_path)
    bad = tmp_path / "bad.relations"
    bad.write_text("1 2 3\n")
    assert main(["relations", str(est), "--relations", str(bad)]) == 2
    err = capsys.readouterr().err
    assert str(bad) in err and "3 fields" in err
    assert main(["relations", str(est), str(tmp_path / "none.txt"), "--relations",
                 str(rel)]) == 2
    cap = capsys.readouterr()
    assert "none.txt" in cap.err and "est.txt" in cap.out     # the good one still scored


# ------------------------------------------------------------------ the real files
_REAL = {"intel": (2984, 6, 0), "aces": (1279, 0, 9), "fr079": (1685, 0, 4),
         "mit-csail": (1172, 0, 1)}


@pytest.mark.parametrize("name", sorted(_REAL))
def test_the_real_relations_files(name: str) -> None:
    path = DATASETS / name / f"{name}.relations"
    if not path.is_file():
        pytest.skip(f"{path} not found (the datasets2d corpus beside the clone)")
    rel = read_relations(path)
    rows, reversed_rows, duplicates = _REAL[name]
    assert len(rel) == rows
    # a trajectory through exactly the relation stamps, the motions made consistent with
    # it: every row placed, the reversed and duplicated ones counted
    stamps = np.unique(np.concatenate([rel.t1, rel.t2]))
    tr = _walk(stamps.shape[0], 3)
    tr = Trajectory.from_xy_yaw(stamps, tr.positions[:, 0], tr.positions[:, 1], tr.yaw)
    i = np.searchsorted(stamps, rel.t1)
    j = np.searchsorted(stamps, rel.t2)
    r = relations(tr, _true_relations(tr, i, j))
    assert (r.n, r.n_unplaced, r.n_reversed) == (rows, 0, reversed_rows)
    assert r.trans_max < 1e-8
    assert relations(tr, rel).n_duplicates == duplicates


def test_mit_csail_odometry_against_its_relations() -> None:
    """The odometry of the original CARMEN log (FLASER lines) is placed on every relation
    with the 5-decimal stamps matched (stamp_tol), and its error does not depend on where
    the log's frame is."""
    log = DATASETS / "mit-csail" / "mit-csail.clf"
    path = DATASETS / "mit-csail" / "mit-csail.relations"
    if not (log.is_file() and path.is_file()):
        pytest.skip(f"{log} not found (the datasets2d corpus beside the clone)")
    t, x, y, th = [], [], [], []
    with open(log) as f:
        for line in f:
            if line.startswith("FLASER "):
                v = line.split()
                k = int(v[1]) + 2
                x.append(float(v[k + 3]))
                y.append(float(v[k + 4]))
                th.append(float(v[k + 5]))
                t.append(float(v[k + 6]))
    odom = Trajectory.from_xy_yaw(t, x, y, th, source=str(log))
    rel = read_relations(path)
    r = relations(odom, rel)
    assert (r.n, r.n_unplaced) == (1172, 0)
    assert relations(odom, rel, stamp_tol=1e-6).n < 1172     # 5 vs 6 decimals
    assert 0 < r.trans_abs_mean < 10 and r.rot_max <= 180
    moved = relations(_moved(odom, 100.0, -40.0, 2.0), rel)
    np.testing.assert_allclose(moved.trans_errors, r.trans_errors, atol=1e-7)


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.booleans(), st.booleans())
def test_the_lookup_places_poses_as_interpolate_poses_does(seed: int, planar: bool,
                                                           interpolate: bool) -> None:
    """The relations error looks its poses up on its own (one gather of the poses before
    and after each stamp; a planar trajectory's heading interpolated on the shorter arc,
    any other by slerp): it places the same relations, with the same poses, as the general
    association of section 6b (interpolate_poses) would."""
    from slamq.metrics.relations import _poses_at, _yaw
    from slamq.metrics.sync import interpolate_poses

    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 60))
    t = 50 + np.cumsum(rng.choice([0.0, 0.1, 0.3, 1.0], n))  # equal stamps too
    pos = np.column_stack([rng.normal(0, 3, (n, 2)), np.zeros(n)])
    if planar:
        tr = Trajectory.from_xy_yaw(t, pos[:, 0], pos[:, 1], rng.uniform(-4, 4, n))
    else:
        tr = Trajectory(t, pos, rng.normal(size=(n, 4)))
    times = np.concatenate([rng.choice(t, 20), rng.uniform(t[0] - 1, t[-1] + 1, 20)])
    ok, interp, p, q = interpolate_poses(tr, times, interpolate=interpolate, max_gap=0.5)
    ok2, interp2, x, y, yaw = _poses_at(tr, times, interpolate, 0.5, 1e-5)
    np.testing.assert_array_equal(ok, ok2)
    np.testing.assert_array_equal(interp, interp2)
    np.testing.assert_allclose(x[ok], p[ok, 0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(y[ok], p[ok, 1], rtol=0, atol=1e-12)
    d = np.angle(np.exp(1j * (yaw[ok] - _yaw(q[ok]))))
    np.testing.assert_allclose(d, 0, atol=1e-9)
