"""The Rust passes of the ATE (rust/src/ate.rs) and the one-pass TUM reader
(rust/src/table.rs) against their numpy twins: ``ate`` equals ``ate_numpy``,
``matching_indices`` equals ``matching_indices_numpy``, ``read_tum`` equals the general
table reader + the ``Trajectory`` constructor, with the same errors (type and message).
The comparison with evo itself is tests/metrics/test_trajectory_evo.py."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from slamq import _core
from slamq.errors import TrajectoryError
from slamq.metrics.ate import STAT_NAMES, ate, ate_numpy
from slamq.metrics.sync import matching_indices, matching_indices_numpy
from slamq.models import Trajectory
from slamq.sources.trajectories import _read_table, load_trajectory, read_tum

TRAJ = Path(__file__).resolve().parents[1] / "data" / "trajectories" / "slam_comparison_tools"
ALIGNS = ("se2", "se3", "sim3", "origin", "none")
# The alignment's sums are taken in another order than numpy's (chunked vs pairwise/BLAS):
# the statistics differ by rounding only.
REL = 1e-12


def _same(a, b) -> None:
    assert a.n == b.n
    assert np.array_equal(a.timestamps, b.timestamps)
    assert np.allclose(a.errors, b.errors, rtol=0, atol=REL * max(1.0, float(b.max)))
    for k in STAT_NAMES:
        x, y = getattr(a, k), getattr(b, k)
        assert abs(x - y) <= REL * max(1.0, abs(y)), (k, x, y)
    assert np.allclose(a.alignment.matrix(), b.alignment.matrix(), rtol=0, atol=1e-12)
    assert a.to_dict().keys() == b.to_dict().keys()


def _both(gt, est, **kw):
    """Both results, or both errors (same type and message)."""
    try:
        want = ate_numpy(gt, est, **kw)
    except TrajectoryError as exc:
        with pytest.raises(TrajectoryError) as got:
            ate(gt, est, **kw)
        assert str(got.value) == str(exc)
        return None
    got = ate(gt, est, **kw)
    _same(got, want)
    return got


def _walk(n: int, seed: int, z: bool = True) -> Trajectory:
    rng = np.random.default_rng(seed)
    t = 100.0 + np.arange(n) * 0.05
    p = np.cumsum(rng.normal(size=(n, 3)) * [0.1, 0.1, 0.02 if z else 0.0], axis=0)
    yaw = np.cumsum(rng.normal(size=n) * 0.05)
    q = np.zeros((n, 4))
    q[:, 0], q[:, 3] = np.cos(yaw / 2), np.sin(yaw / 2)
    return Trajectory(t, p, q)


def _moved(tr: Trajectory, seed: int, jitter: float = 0.004, scale: float = 1.0) -> Trajectory:
    rng = np.random.default_rng(seed)
    a = 0.8
    r = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1.0]])
    p = scale * tr.positions @ r.T + [1.0, -2.0, 0.3] + rng.normal(size=tr.positions.shape) * 0.05
    t = tr.timestamps + rng.uniform(-jitter, jitter, size=len(tr))
    return Trajectory(np.sort(t), p, tr.orientations)


@pytest.mark.parametrize("align", ALIGNS)
def test_rust_ate_equals_numpy_on_the_pose_logs(align):
    logs = sorted(TRAJ.glob("*/*_pose_log.csv"))
    assert logs
    for log in logs:
        kw = {"unsorted": "last"}
        est = load_trajectory(log, columns={"t": "timestamp_sec", "x": "slam_x", "y": "slam_y"},
                              **kw)
        gt = load_trajectory(log, columns={"t": "timestamp_sec", "x": "gt_x", "y": "gt_y"}, **kw)
        assert _both(gt, est, align=align) is not None


@pytest.mark.parametrize("align", ALIGNS)
@pytest.mark.parametrize("max_dt, offset", [(0.01, 0.0), (0.0, 0.0), (0.003, 0.02),
                                             (0.05, -0.1), (1.0, 0.0)])
def test_rust_ate_equals_numpy_on_generated_walks(align, max_dt, offset):
    gt = _walk(20_000, 1)  # more than one chunk of every pass, and than 4096 poses
    est = _moved(gt, 2, scale=1.3 if align == "sim3" else 1.0)
    _both(gt, est, align=align, max_dt=max_dt, offset=offset)
    _both(gt, est.subset(np.arange(0, len(est), 3)), align=align, max_dt=max_dt, offset=offset)
    _both(gt.subset(np.arange(0, len(gt), 7)), est, align=align, max_dt=max_dt, offset=offset)


def test_rust_ate_equals_numpy_on_planar_walks_and_exact_copies():
    gt = _walk(5000, 3, z=False)
    for align in ALIGNS:
        r = _both(gt, gt, align=align)
        assert r.rmse < 1e-9
        _both(gt, _moved(gt, 4), align=align)


def test_duplicate_timestamps_and_ties():
    t = np.array([0.0, 0.1, 0.1, 0.1, 0.2, 0.3, 0.3, 0.4, 0.5, 0.6])
    p = np.column_stack([np.arange(10.0), np.arange(10.0) ** 2 / 7, np.sin(np.arange(10.0))])
    gt = Trajectory(t, p)
    est = Trajectory(t[::2] + 0.05, p[::2] + 0.01)  # every estimate stamp halfway: ties
    for align in ALIGNS:
        _both(gt, est, align=align, max_dt=0.05)
        _both(est, gt, align=align, max_dt=0.05)
        _both(gt, gt, align=align, max_dt=0.0)


def test_no_match_and_too_few_poses_raise_the_same_errors():
    gt = _walk(50, 5)
    far = Trajectory(gt.timestamps + 100.0, gt.positions)
    for align in ALIGNS:
        with pytest.raises(TrajectoryError, match="no pose is within max_dt"):
            ate(gt, far, align=align)
        assert _both(gt, far, align=align) is None
    one = gt.subset(np.arange(1))
    two = gt.subset(np.arange(2))
    assert _both(gt, one, align="se2") is None  # se2 needs 2 distinct x-y positions
    assert _both(gt, two, align="se3") is None  # se3 needs 3 distinct positions
    assert _both(gt, two, align="sim3") is None
    _both(gt, two, align="se2")
    _both(gt, one, align="origin")
    _both(gt, one, align="none")
    with pytest.raises(TrajectoryError, match="se3 needs at least 3 distinct"):
        ate(gt, two, align="se3")


def test_degenerate_alignments_raise_the_same_errors():
    n = 6000
    t = np.arange(n) * 0.1
    # collinear, exact in binary: the covariance has rank 1 exactly
    line = np.column_stack([np.arange(n) * 0.5, np.zeros(n), np.zeros(n)])
    gt = Trajectory(t, line + 1.0)
    est = Trajectory(t, line)
    for align in ("se3", "sim3"):
        assert _both(gt, est, align=align) is None
        with pytest.raises(TrajectoryError, match="degenerate alignment"):
            ate(gt, est, align=align)
    # the first 4096 positions equal: the distinct-points check looks at every pair
    p = np.zeros((n, 3))
    p[5000:, 0] = 1.0
    p[5500:, 1] = 1.0
    same = Trajectory(t, p.copy())
    _both(gt, same, align="se2")
    _both(gt, same, align="se3")
    p[5500:, 1] = 0.0
    assert _both(gt, Trajectory(t, p.copy()), align="se3") is None  # two distinct points only
    assert _both(gt, Trajectory(t, np.zeros((n, 3))), align="se2") is None


def test_bad_arguments_raise_as_before():
    gt = _walk(30, 6)
    for kw in ({"max_dt": -1.0}, {"max_dt": float("nan")}, {"offset": float("inf")},
               {"align": "se4"}):
        assert _both(gt, gt, **kw) is None


@settings(max_examples=150, deadline=None)
@given(
    st.lists(st.floats(-5, 5, allow_nan=False), min_size=0, max_size=60),
    st.lists(st.floats(-5, 5, allow_nan=False), min_size=1, max_size=60),
    st.sampled_from([0.0, 0.01, 0.1, 0.5, 3.0]),
    st.sampled_from([0.0, 0.05, -0.3, 1e-9]),
    st.booleans(),
)
def test_matching_equals_numpy(s1, s2, max_dt, offset, sort1):
    a = np.array(s1, dtype=np.float64)
    if sort1:
        a = np.sort(a)
    b = np.sort(np.round(np.array(s2), 1))  # rounded: duplicates and exact ties
    got = matching_indices(a, b, max_dt, offset)
    want = matching_indices_numpy(a, b, max_dt, offset)
    assert got[0].tolist() == want[0].tolist()
    assert got[1].tolist() == want[1].tolist()


def test_matching_of_a_million_sorted_stamps_equals_numpy():
    rng = np.random.default_rng(8)
    s2 = np.arange(1_000_000) * 0.01 + 1.6e9
    s1 = np.sort(s2[::2] + rng.uniform(-0.006, 0.006, size=500_000))
    for max_dt, off in ((0.01, 0.0), (0.004, 0.001)):
        got = matching_indices(s1, s2, max_dt, off)
        want = matching_indices_numpy(s1, s2, max_dt, off)
        assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])


def test_core_passes_refuse_bad_arrays():
    p = np.zeros((3, 3))
    i = np.arange(3)
    with pytest.raises(ValueError, match="out of range"):
        _core.ate_errors(p, p, i, i + 1, None, [0.0, 0.0, 0.0], 1.0)
    with pytest.raises(ValueError, match="no associated pair"):
        _core.ate_moments(p, p, i[:0], i[:0], 3)
    with pytest.raises(ValueError, match="dims"):
        _core.ate_moments(p, p, i, i, 4)
    with pytest.raises(ValueError, match="C-contiguous"):
        _core.ate_errors(np.zeros((3, 6))[:, ::2], p, i, i, None, [0.0, 0.0, 0.0], 1.0)


# ---------------------------------------------------------------- the one-pass TUM reader
def _general(path: Path) -> Trajectory:
    arr = _read_table(path, sep="ws")
    return Trajectory(arr[:, 0], arr[:, 1:4], arr[:, [7, 4, 5, 6]], source=str(path))


def _write(path: Path, rows: np.ndarray, header: str = "# t x y z qx qy qz qw\n") -> Path:
    with open(path, "w") as f:
        f.write(header)
        np.savetxt(f, rows, fmt="%.17g")
    return path


def test_read_tum_equals_the_general_reader_bit_for_bit(tmp_path):
    rng = np.random.default_rng(9)
    n = 300_000  # several blocks of the reader
    rows = np.column_stack([
        np.sort(rng.uniform(0, 1e4, n)), rng.normal(size=(n, 3)) * 100,
        rng.normal(size=(n, 4)) * rng.uniform(1e-6, 1e3, size=(n, 1))])
    p = _write(tmp_path / "t.txt", rows)
    assert _core.read_tum(p) is not None
    fast, ref = read_tum(p), _general(p)
    for k in ("timestamps", "positions", "orientations"):
        a, b = getattr(fast, k), getattr(ref, k)
        assert a.dtype == b.dtype and a.shape == b.shape and a.flags.c_contiguous
        assert np.array_equal(a, b), k
        assert not a.flags.writeable
    assert fast.meta == {"format": "tum"} and fast.source == str(p)


OK = "0.1 0 0 0 0 0 0 1\n"


@pytest.mark.parametrize("text, match", [
    (OK + "0.2 1 2 3 0 0 0 0\n", "zero quaternion in pose 2"),
    ("0.2 1 2 3 0 0 0 0\n" + OK, "zero quaternion in pose 1"),
    (OK + "0.05 1 2 3 0 0 0 1\n", "non-monotonic timestamps: pose 2"),
    (OK + "0.2 1 2 3e400 0 0 0 1\n", "NaN or infinite position in pose 2"),
    ("1e400 1 2 3 0 0 0 1\n" + OK, "NaN or infinite timestamp in pose 1"),
    (OK + "0.2 1 2 3 0 0 0 nan\n", "missing or NaN value in data row 2"),
    (OK + "0.2 1 2 3 0 0 1\n", "missing or NaN value in data row 2"),
    ("0.1 0 0 0 0 0 1\n0.2 1 2 3 0 0 1\n", "needs 8 numbers per row, found 7"),
    ("# only a comment\n", "empty file"),
])
def test_read_tum_leaves_bad_files_to_the_general_reader(tmp_path, text, match):
    p = tmp_path / "bad.txt"
    p.write_text(text)
    assert _core.read_tum(p) is None
    with pytest.raises(TrajectoryError, match=match):
        load_trajectory(p, format="tum")


def test_read_tum_unsorted_policies_still_apply(tmp_path):
    p = tmp_path / "restart.txt"
    p.write_text("0.1 0 0 0 0 0 0 1\n0.2 1 0 0 0 0 0 1\n0.0 2 0 0 0 0 0 1\n0.1 3 0 0 0 0 0 1\n")
    assert _core.read_tum(p) is None
    assert load_trajectory(p, unsorted="last").positions[:, 0].tolist() == [2.0, 3.0]
    assert load_trajectory(p, unsorted="sort").positions[:, 0].tolist() == [2.0, 0.0, 3.0, 1.0]
    empty = tmp_path / "empty.txt"
    empty.write_text("# nothing\n")
    assert _core.read_tum(empty) is None
    assert _core.read_tum(tmp_path / "absent.txt") is None


def test_results_do_not_depend_on_the_thread_count(tmp_path):
    import subprocess
    import sys

    from conftest import slamq_env

    gt = _walk(60_000, 11)
    gt.write_tum(tmp_path / "gt.txt")
    _moved(gt, 12).write_tum(tmp_path / "est.txt")
    code = (
        "import hashlib; from slamq import load_trajectory; from slamq.metrics.ate import ate\n"
        f"g = load_trajectory({str(tmp_path / 'gt.txt')!r})\n"
        f"e = load_trajectory({str(tmp_path / 'est.txt')!r})\n"
        "for a in ('se2', 'se3', 'sim3'):\n"
        "    r = ate(g, e, align=a)\n"
        "    print(a, [v.hex() for v in r.stats().values() if isinstance(v, float)],\n"
        "          hashlib.sha256(r.errors.tobytes() + e.orientations.tobytes()).hexdigest())\n"
    )
    out = []
    for threads in ("1", "3"):
        env = slamq_env() | {"RAYON_NUM_THREADS": threads}
        out.append(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                                  env=env, check=True, timeout=120).stdout)
    assert out[0] == out[1] and out[0].count("\n") == 3
