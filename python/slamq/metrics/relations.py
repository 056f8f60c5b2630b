"""The relations error of Kümmerle et al. 2009 (docs/spec.md section 6a).

For each ground-truth relation ``(t1, t2, d*)`` -- the planar motion from the robot's pose
at ``t1`` to its pose at ``t2``, in the frame of the pose at ``t1`` -- the trajectory's own
motion ``d = x1^-1 + x2`` between its poses at ``t1`` and ``t2`` is compared with it:
``e = d (-) d* = d*^-1 + d`` (SE(2) composition). The translational error is the norm of
``e``'s translation (m), the rotational error the absolute value of its angle wrapped to
[-pi, pi) (deg). Reported as Kümmerle et al. and the published tables (Hess et al. 2016,
Table II) do: absolute and squared errors, mean and standard deviation, and the maximum.

Vectorised numpy: the poses are looked up with one ``searchsorted`` over all stamps
(3,000 relations over 30,000 poses in well under a millisecond; benches/bench_relations.py).
"""

from __future__ import annotations

import math

import numpy as np

from slamq.errors import TrajectoryError
from slamq.metrics.sync import MAX_GAP, STAMP_TOL, interpolate_poses
from slamq.models.relations import Relations, RelationsResult
from slamq.models.trajectory import Trajectory

__all__ = ["relations", "invert_motion", "wrap_angle"]


def wrap_angle(a: np.ndarray) -> np.ndarray:
    """Angles wrapped to [-pi, pi) radians.

    Examples
    --------
    >>> import numpy as np
    >>> wrap_angle(np.array([3 * np.pi / 2, -np.pi, np.pi])).round(6).tolist()
    [-1.570796, -3.141593, -3.141593]
    """
    return np.mod(np.asarray(a, dtype=np.float64) + math.pi, 2.0 * math.pi) - math.pi


def invert_motion(m: np.ndarray) -> np.ndarray:
    """The inverse SE(2) motions ``(N, 3)`` of ``x, y, yaw`` rows: ``(-R^T t, -yaw)``.

    Examples
    --------
    >>> import numpy as np
    >>> (invert_motion(np.array([[1.0, 0.0, np.pi / 2]])).round(12) + 0.0).tolist()
    [[0.0, 1.0, -1.570796326795]]
    """
    m = np.asarray(m, dtype=np.float64)
    c, s = np.cos(m[:, 2]), np.sin(m[:, 2])
    x, y = m[:, 0], m[:, 1]
    return np.column_stack([-(c * x + s * y), s * x - c * y, -m[:, 2]])


def _yaw(q: np.ndarray) -> np.ndarray:
    """Heading (z-y-x Euler yaw) of quaternions ``(N, 4)`` (w, x, y, z)."""
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    return np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def _duplicates(t1: np.ndarray, t2: np.ndarray) -> int:
    """Rows whose ``(t1, t2)`` pair repeats an earlier row's."""
    order = np.lexsort((t2, t1))
    a, b = t1[order], t2[order]
    return int(((a[1:] == a[:-1]) & (b[1:] == b[:-1])).sum())


def relations(
    trajectory: Trajectory,
    relations: Relations,
    *,
    interpolate: bool = False,
    max_gap: float = MAX_GAP,
    stamp_tol: float = STAMP_TOL,
) -> RelationsResult:
    """The relations error of a trajectory (Kümmerle et al. 2009; docs/spec.md 6a).

    Parameters
    ----------
    trajectory : Trajectory
        The estimate (:func:`slamq.load_trajectory`); its x, y and heading are used.
    relations : Relations
        The ground truth (:func:`slamq.sources.relations.read_relations`).
    interpolate : bool
        Place a relation stamp between the two neighbouring poses when no pose is within
        ``stamp_tol`` of it (default: only poses at the stamp count).
    max_gap : float
        Largest time between the two poses a stamp is interpolated between, seconds.
    stamp_tol : float
        Largest difference of a stamp and a pose's timestamp that counts as that pose.

    Returns
    -------
    RelationsResult
        Translational (m, m^2) and rotational (deg, deg^2) error: absolute and squared
        mean and std, the maxima; the count of relations placed and not placed.

    Raises
    ------
    TrajectoryError
        Not a Trajectory / Relations, bad ``max_gap`` / ``stamp_tol``, or no relation
        could be placed on the trajectory.

    Examples
    --------
    >>> import numpy as np
    >>> from slamq.models import Trajectory
    >>> from slamq.models.relations import Relations
    >>> tr = Trajectory.from_xy_yaw([0.0, 1.0, 2.0], [0.0, 1.0, 1.0], [0, 0, 1.0],
    ...                             [0, np.pi / 2, np.pi / 2])
    >>> rel = Relations([0.0, 1.0], [1.0, 2.0], [[1.0, 0.0, np.pi / 2], [1.1, 0.0, 0.0]])
    >>> r = relations(tr, rel)
    >>> round(r.trans_abs_mean, 12), round(r.trans_max, 12), r.rot_max, r.n
    (0.05, 0.1, 0.0, 2)
    """
    if not isinstance(trajectory, Trajectory):
        raise TrajectoryError(f"trajectory must be a Trajectory, not {type(trajectory).__name__}"
                              " (read files with slamq.load_trajectory)")
    if not isinstance(relations, Relations):
        raise TrajectoryError(f"relations must be Relations, not {type(relations).__name__} "
                              "(read files with slamq.load_relations)")
    n_rel = len(relations)
    rev = relations.t2 < relations.t1
    t1 = np.where(rev, relations.t2, relations.t1)
    t2 = np.where(rev, relations.t1, relations.t2)
    truth = relations.motion
    if rev.any():
        truth = truth.copy()
        truth[rev] = invert_motion(truth[rev])
    placed, interp, pos, quat = interpolate_poses(
        trajectory, np.concatenate([t1, t2]), interpolate=interpolate, max_gap=max_gap,
        stamp_tol=stamp_tol)
    ok = placed[:n_rel] & placed[n_rel:]
    rows = np.flatnonzero(ok)
    n = int(rows.shape[0])
    if n == 0:
        raise TrajectoryError(
            f"{trajectory.source}: none of the {n_rel} relations of {relations.source} could "
            f"be placed (no pose within {stamp_tol} s of both stamps"
            + (f", nor neighbours at most {max_gap} s apart" if interpolate else
               "; interpolate=True / --interpolate places stamps between poses")
            + f"; trajectory {trajectory.timestamps[0]:.6f}..{trajectory.timestamps[-1]:.6f} s,"
            f" relations {t1.min():.6f}..{t2.max():.6f} s)")
    p1, p2 = pos[rows, :2], pos[rows + n_rel, :2]
    yaw = _yaw(quat)
    th1, th2 = yaw[rows], yaw[rows + n_rel]
    # d = x1^-1 + x2, in the frame of x1
    c1, s1 = np.cos(th1), np.sin(th1)
    dx, dy = p2[:, 0] - p1[:, 0], p2[:, 1] - p1[:, 1]
    d = np.column_stack([c1 * dx + s1 * dy, -s1 * dx + c1 * dy])
    # e = d*^-1 + d: translation R*^T (t_d - t*), angle th_d - th*
    g = truth[rows]
    cg, sg = np.cos(g[:, 2]), np.sin(g[:, 2])
    ex, ey = d[:, 0] - g[:, 0], d[:, 1] - g[:, 1]
    et = np.hypot(cg * ex + sg * ey, -sg * ex + cg * ey)
    er = np.degrees(np.abs(wrap_angle((th2 - th1) - g[:, 2])))
    et2, er2 = et * et, er * er
    return RelationsResult(
        trans_abs_mean=float(et.mean()), trans_abs_std=float(et.std()),
        trans_sq_mean=float(et2.mean()), trans_sq_std=float(et2.std()),
        trans_max=float(et.max()),
        rot_abs_mean=float(er.mean()), rot_abs_std=float(er.std()),
        rot_sq_mean=float(er2.mean()), rot_sq_std=float(er2.std()),
        rot_max=float(er.max()),
        n=n,
        n_relations=n_rel,
        n_unplaced=n_rel - n,
        n_interpolated=int((interp[:n_rel] | interp[n_rel:])[rows].sum()),
        n_reversed=int(rev.sum()),
        n_duplicates=_duplicates(t1, t2),
        trans_errors=et,
        rot_errors=er,
        placed=rows,
        est_source=trajectory.source,
        relations_source=relations.source,
        params={"interpolate": bool(interpolate), "max_gap": float(max_gap),
                "stamp_tol": float(stamp_tol)},
    )
