"""The relations error of Kümmerle et al. 2009 (docs/spec.md section 6a).

For each ground-truth relation ``(t1, t2, d*)`` -- the planar motion from the robot's pose
at ``t1`` to its pose at ``t2``, in the frame of the pose at ``t1`` -- the trajectory's own
motion ``d = x1^-1 + x2`` between its poses at ``t1`` and ``t2`` is compared with it:
``e = d (-) d* = d*^-1 + d`` (SE(2) composition). The translational error is the norm of
``e``'s translation (m), the rotational error the absolute value of its angle wrapped to
[-pi, pi) (deg). Reported as Kümmerle et al. and the published tables (Hess et al. 2016,
Table II) do: absolute and squared errors, mean and standard deviation, and the maximum.

Vectorised numpy: the poses are looked up with one ``searchsorted`` over all stamps, the
pose before and after each gathered once, the heading of a planar trajectory interpolated
directly (benches/bench_relations.py: 3,000 relations over 30,000 poses, exact or
interpolated, in a few milliseconds). The relations' forward form and duplicate count are
computed once per :class:`~slamq.models.relations.Relations`.
"""

from __future__ import annotations

import math

import numpy as np

from slamq.errors import TrajectoryError
from slamq.metrics.sync import MAX_GAP, STAMP_TOL, slerp
from slamq.models.relations import Relations, RelationsResult, invert_motion
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


def _yaw(q: np.ndarray) -> np.ndarray:
    """Heading (z-y-x Euler yaw) of quaternions ``(N, 4)`` (w, x, y, z)."""
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    return np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def _poses_at(trajectory: Trajectory, times: np.ndarray, interpolate: bool, max_gap: float,
              stamp_tol: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                         np.ndarray]:
    """``(placed, interpolated, x, y, yaw)`` of the trajectory at ``times``: the rule of
    :func:`slamq.metrics.sync.interpolate_poses` (docs/spec.md 6a), reduced to what the
    relations error uses. One ``searchsorted`` over the times as they come; each time
    gathers the pose before and the pose after it (the same pose when it is placed
    exactly) and mixes them by ``s`` (0 for an exact one). The heading of a planar
    trajectory (orientations about z only) is interpolated along the shorter arc directly,
    which is what slerp of its orientations gives; any other by slerp."""
    t = trajectory.timestamps
    n = t.shape[0]
    hi = np.searchsorted(t, times, side="left")     # the first pose at or after the time
    lo = np.maximum(hi - 1, 0)
    up = np.minimum(hi, n - 1)
    d_lo = np.abs(times - t[lo])
    d_hi = np.abs(t[up] - times)
    exact = np.minimum(d_lo, d_hi) <= stamp_tol
    nearest = np.where(d_hi < d_lo, up, lo)           # a tie: the earlier pose
    if interpolate and n > 1:
        gap = t[up] - t[lo]
        interp = ~exact & (hi >= 1) & (hi <= n - 1) & (gap <= max_gap) & (gap > 0)
        a, b = np.where(interp, lo, nearest), np.where(interp, up, nearest)
        s = np.where(interp, (times - t[lo]) / np.where(interp, gap, 1.0), 0.0)
    else:
        interp = np.zeros(times.shape[0], dtype=bool)
        a = b = nearest
        s = np.zeros(times.shape[0])
    pa, pb = trajectory.positions.take(a, axis=0), trajectory.positions.take(b, axis=0)
    qa, qb = trajectory.orientations.take(a, axis=0), trajectory.orientations.take(b, axis=0)
    x = pa[:, 0] + s * (pb[:, 0] - pa[:, 0])
    y = pa[:, 1] + s * (pb[:, 1] - pa[:, 1])
    ya = _yaw(qa)
    if not interp.any():
        return exact, interp, x, y, ya
    if qa[:, 1:3].any() or qb[:, 1:3].any():  # not planar: slerp, as the spec says
        yaw = ya.copy()
        yaw[interp] = _yaw(slerp(qa[interp], qb[interp], s[interp]))
    else:
        yaw = ya + s * wrap_angle(_yaw(qb) - ya)
    return exact | interp, interp, x, y, yaw


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
    if not (np.isfinite(max_gap) and max_gap >= 0):
        raise TrajectoryError(f"max_gap must be a finite number >= 0, not {max_gap!r}")
    if not (np.isfinite(stamp_tol) and stamp_tol >= 0):
        raise TrajectoryError(f"stamp_tol must be a finite number >= 0, not {stamp_tol!r}")
    t1, t2, truth, rev = relations.forward
    placed, interp, px, py, pyaw = _poses_at(trajectory, np.concatenate([t1, t2]),
                                             bool(interpolate), max_gap, stamp_tol)
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
    th1, th2 = pyaw[rows], pyaw[rows + n_rel]
    # d = x1^-1 + x2, in the frame of x1
    c1, s1 = np.cos(th1), np.sin(th1)
    dx, dy = px[rows + n_rel] - px[rows], py[rows + n_rel] - py[rows]
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
        n_duplicates=relations.n_duplicates,
        trans_errors=et,
        rot_errors=er,
        placed=rows,
        est_source=trajectory.source,
        relations_source=relations.source,
        params={"interpolate": bool(interpolate), "max_gap": float(max_gap),
                "stamp_tol": float(stamp_tol)},
    )
