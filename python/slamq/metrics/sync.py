"""Association of two trajectories by nearest timestamp (evo's ``associate_trajectories``).

The rule is evo's, vectorised: the trajectory with fewer poses (the estimate when both
have as many) is the "short" one; each of its poses is matched with the nearest pose of
the long one whose (offset) timestamp is within ``max_dt``; a tie goes to the earlier
pose. A long-trajectory pose may be matched more than once; short poses without a match
are dropped. ``offset`` is added to the estimate's timestamps.

:func:`interpolate_poses` places poses at arbitrary times instead (docs/spec.md 6a, 6b): a
pose whose timestamp is within ``stamp_tol`` of the time as it is, else the pose between
its two neighbours (positions linear, orientations by slerp) when they are at most
``max_gap`` apart. :func:`associate_interpolated` uses it to give every ground-truth pose
an estimate pose at its own time.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from slamq import native
from slamq.errors import TrajectoryError
from slamq.models.trajectory import Trajectory
from slamq.params import SETTINGS

__all__ = ["matching_indices", "matching_indices_numpy", "associate", "interpolate_poses",
           "associate_interpolated", "slerp", "evenly_spread", "MAX_GAP", "STAMP_TOL"]

#: Default largest time between the two poses a pose is interpolated between, seconds: the
#: scans of the classic 2D laser logs are 0.1-0.25 s apart, so one or two dropped scans
#: still interpolate, a pause of the estimate's output does not.
MAX_GAP = 0.5
#: Default largest difference of a time and a pose's timestamp that still counts as that
#: pose (no interpolation), seconds: relation stamps printed with 5 decimals (MIT CSAIL)
#: are up to 5 us off the log's 6-decimal stamps.
STAMP_TOL = 1e-5


def matching_indices(
    stamps_1: np.ndarray, stamps_2: np.ndarray, max_dt: float = SETTINGS.max_dt.default,
    offset_2: float = SETTINGS.offset.default
) -> tuple[np.ndarray, np.ndarray]:
    """Indices ``(i1, i2)`` of the best match in ``stamps_2 + offset_2`` of each stamp_1.

    ``stamps_2`` must be sorted (non-decreasing). Same result as evo's
    ``sync.matching_time_indices`` for sorted stamps. Computed by the Rust core
    (``slamq._core.match_stamps``, one pass over sorted stamps); equal to
    :func:`matching_indices_numpy`, its vectorised numpy twin.

    Examples
    --------
    >>> import numpy as np
    >>> matching_indices(np.array([0.0, 1.0, 2.5]), np.array([0.005, 1.02, 2.5]), 0.01)
    (array([0, 2]), array([0, 2]))
    """
    s1 = np.ascontiguousarray(stamps_1, dtype=np.float64)
    s2 = np.ascontiguousarray(stamps_2, dtype=np.float64)
    if s1.ndim != 1 or s2.ndim != 1 or s2.shape[0] == 0:
        return matching_indices_numpy(stamps_1, stamps_2, max_dt, offset_2)  # as it fails
    return native.match_stamps(s1, s2, float(max_dt), float(offset_2))


def matching_indices_numpy(
    stamps_1: np.ndarray, stamps_2: np.ndarray, max_dt: float = SETTINGS.max_dt.default,
    offset_2: float = SETTINGS.offset.default
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`matching_indices` in numpy: the numpy twin the Rust core is tested against.

    Examples
    --------
    >>> import numpy as np
    >>> matching_indices_numpy(np.array([0.0, 1.0, 2.5]), np.array([0.005, 1.02, 2.5]), 0.01)
    (array([0, 2]), array([0, 2]))
    """
    s1 = np.asarray(stamps_1, dtype=np.float64)
    s2 = np.asarray(stamps_2, dtype=np.float64) + offset_2
    max_dt = float(max_dt)
    inside = ~((s1 < s2[0] - max_dt) | (s1 > s2[-1] + max_dt))
    idx = np.searchsorted(s2, s1, side="right")
    np.minimum(idx, s2.shape[0] - 1, out=idx)
    diff_ub = s2[idx] - s1
    diff_lb = np.where(idx > 0, s1 - s2[np.maximum(idx - 1, 0)], np.inf)
    pick_ub = (diff_ub <= max_dt) & (diff_ub < diff_lb)
    pick_lb = ~pick_ub & (diff_lb <= max_dt) & (diff_lb <= diff_ub)
    keep = inside & (pick_ub | pick_lb)
    i1 = np.flatnonzero(keep)
    i2 = np.where(pick_ub, idx, idx - 1)[keep]
    return i1, i2


def associate(
    gt: Trajectory,
    est: Trajectory,
    *,
    max_dt: float = SETTINGS.max_dt.default,
    offset: float = SETTINGS.offset.default,
    matcher: Callable[..., tuple[np.ndarray, np.ndarray]] = matching_indices,
) -> tuple[np.ndarray, np.ndarray]:
    """Pairs of indices ``(gt_index, est_index)`` of the associated poses.

    Parameters
    ----------
    gt, est : Trajectory
    max_dt : float
        Largest accepted time difference, seconds (evo's ``--t_max_diff``, 0.01).
    offset : float
        Seconds added to the estimate's timestamps (evo's ``--t_offset``).
    matcher : callable
        :func:`matching_indices` (Rust) or :func:`matching_indices_numpy` (its numpy twin).

    Raises
    ------
    TrajectoryError
        No pair of poses is within ``max_dt``.

    Examples
    --------
    >>> import numpy as np
    >>> from slamq.models import Trajectory
    >>> gt = Trajectory.from_xy_yaw([0.0, 0.1, 0.2], [0, 1, 2], [0, 0, 0])
    >>> est = Trajectory.from_xy_yaw([0.101, 0.199], [1, 2], [0, 0])
    >>> associate(gt, est)
    (array([1, 2]), array([0, 1]))
    """
    if not np.isfinite(max_dt) or max_dt < 0:
        raise TrajectoryError(f"max_dt must be a finite number >= 0, not {max_dt!r}")
    if not np.isfinite(offset):
        raise TrajectoryError(f"offset must be finite, not {offset!r}")
    second_longer = len(est) > len(gt)
    if second_longer:
        i_short, i_long = matcher(gt.timestamps, est.timestamps, max_dt, offset)
        gi, ei = i_short, i_long
    else:
        i_short, i_long = matcher(est.timestamps, gt.timestamps, max_dt, -offset)
        gi, ei = i_long, i_short
    if gi.shape[0] == 0:
        raise TrajectoryError(
            f"{est.source}: no pose is within max_dt={max_dt} s of a pose of {gt.source} "
            f"(offset {offset} s; estimate {est.timestamps[0]:.6f}..{est.timestamps[-1]:.6f} s,"
            f" ground truth {gt.timestamps[0]:.6f}..{gt.timestamps[-1]:.6f} s)"
        )
    return gi, ei


def slerp(q0: np.ndarray, q1: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Spherical linear interpolation of unit quaternions ``(N, 4)`` at fractions ``s``.

    The shorter arc is taken (``q1`` is negated when ``q0 . q1 < 0``); nearly equal
    quaternions are interpolated linearly. The result is normalised.

    Examples
    --------
    >>> import numpy as np
    >>> from slamq.models.trajectory import yaw_to_quat
    >>> q = slerp(yaw_to_quat(np.array([0.0])), yaw_to_quat(np.array([1.0])), np.array([0.25]))
    >>> round(float(2 * np.arctan2(q[0, 3], q[0, 0])), 12)
    0.25
    """
    q0 = np.asarray(q0, dtype=np.float64)
    q1 = np.asarray(q1, dtype=np.float64)
    s = np.asarray(s, dtype=np.float64)[:, None]
    d = np.einsum("ij,ij->i", q0, q1)
    q1 = np.where(d[:, None] < 0, -q1, q1)
    d = np.minimum(np.abs(d), 1.0)[:, None]
    theta = np.arccos(d)
    sin = np.sin(theta)
    small = sin < 1e-9
    safe = np.where(small, 1.0, sin)
    w0 = np.where(small, 1.0 - s, np.sin((1.0 - s) * theta) / safe)
    w1 = np.where(small, s, np.sin(s * theta) / safe)
    out = w0 * q0 + w1 * q1
    return out / np.linalg.norm(out, axis=1, keepdims=True)


def interpolate_poses(
    traj: Trajectory,
    times: np.ndarray,
    *,
    interpolate: bool = True,
    max_gap: float = MAX_GAP,
    stamp_tol: float = STAMP_TOL,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The poses of ``traj`` at ``times``: ``(placed, interpolated, positions, orientations)``.

    A time within ``stamp_tol`` of a timestamp takes that pose (the nearest; a tie goes to
    the earlier pose). Otherwise, when ``interpolate`` is true and the poses just before and
    just after the time are at most ``max_gap`` apart, the pose between them: position
    linear in time, orientation by :func:`slerp` (for planar poses: the heading along the
    shorter arc). Any other time is not placed.

    Returns
    -------
    placed, interpolated : ndarray of bool (M,)
        Which times got a pose, and which of those were interpolated.
    positions, orientations : ndarray (M, 3), (M, 4)
        The poses (rows of times not placed are zeros / identity).

    Examples
    --------
    >>> import numpy as np
    >>> from slamq.models import Trajectory
    >>> tr = Trajectory.from_xy_yaw([0.0, 1.0, 5.0], [0.0, 2.0, 0.0], [0.0, 0.0, 0.0])
    >>> ok, interp, p, q = interpolate_poses(tr, np.array([0.25, 1.0, 3.0, 9.0]), max_gap=1.0)
    >>> ok.tolist(), interp.tolist(), p[:2, 0].tolist()
    ([True, True, False, False], [True, False, False, False], [0.5, 2.0])
    """
    if not (np.isfinite(max_gap) and max_gap >= 0):
        raise TrajectoryError(f"max_gap must be a finite number >= 0, not {max_gap!r}")
    if not (np.isfinite(stamp_tol) and stamp_tol >= 0):
        raise TrajectoryError(f"stamp_tol must be a finite number >= 0, not {stamp_tol!r}")
    t = traj.timestamps
    q = np.asarray(times, dtype=np.float64)
    n = t.shape[0]
    m = q.shape[0]
    # the times are placed in sorted order (one searchsorted, and gathers that walk the
    # trajectory forwards: several times faster on a long trajectory than random order),
    # then put back in the caller's order
    order = None
    if m > 1 and not bool((q[1:] >= q[:-1]).all()):
        order = np.argsort(q, kind="stable")
        q = q[order]
    hi = np.searchsorted(t, q, side="left")        # the first pose at or after the time
    lo = np.clip(hi - 1, 0, n - 1)
    up = np.minimum(hi, n - 1)
    d_lo = np.abs(q - t[lo])
    d_hi = np.abs(t[up] - q)
    # exact: the nearest pose, the earlier on a tie
    nearest = np.where(d_hi < d_lo, up, lo)
    exact = np.minimum(d_lo, d_hi) <= stamp_tol
    positions = traj.positions.take(nearest, axis=0)
    orientations = traj.orientations.take(nearest, axis=0)
    if not exact.all():
        positions[~exact] = 0.0
        orientations[~exact] = (1.0, 0.0, 0.0, 0.0)
    interp = np.zeros(m, dtype=bool)
    if interpolate and n > 1:
        # not exact, so t[hi - 1] < time < t[hi]: between poses hi - 1 and hi
        inside = (hi >= 1) & (hi <= n - 1)
        k = np.clip(hi - 1, 0, n - 2)
        gap = t[k + 1] - t[k]
        interp = ~exact & inside & (gap <= max_gap) & (gap > 0)
        if interp.any():
            kk = k[interp]
            s = (q[interp] - t[kk]) / gap[interp]
            p0, p1 = traj.positions[kk], traj.positions[kk + 1]
            positions[interp] = p0 + s[:, None] * (p1 - p0)
            orientations[interp] = slerp(traj.orientations[kk], traj.orientations[kk + 1], s)
    if order is not None:
        back = np.empty(m, dtype=np.intp)
        back[order] = np.arange(m)
        exact, interp = exact[back], interp[back]
        positions, orientations = positions[back], orientations[back]
    return exact | interp, interp, positions, orientations


def associate_interpolated(
    gt: Trajectory,
    est: Trajectory,
    *,
    offset: float = SETTINGS.offset.default,
    max_gap: float = MAX_GAP,
    stamp_tol: float = STAMP_TOL,
) -> tuple[np.ndarray, Trajectory]:
    """Every ground-truth pose with the estimate's pose at its time, interpolated.

    The estimate (timestamps + ``offset``) is placed at each ground-truth timestamp by
    :func:`interpolate_poses`; ground-truth poses outside the estimate's span or in a gap
    longer than ``max_gap`` are dropped.

    Returns
    -------
    gt_index : ndarray (K,)
        The ground-truth poses kept.
    est_at : Trajectory
        The estimate's K poses at those times (its own clock: ground-truth time minus
        ``offset``); pair ``gt_index[i]`` with pose ``i``.

    Raises
    ------
    TrajectoryError
        No ground-truth pose could be placed.

    Examples
    --------
    >>> from slamq.models import Trajectory
    >>> gt = Trajectory.from_xy_yaw([0.0, 0.5, 1.0, 3.0], [0, 1, 2, 6], [0, 0, 0, 0])
    >>> est = Trajectory.from_xy_yaw([0.0, 1.0], [0.0, 2.0], [0.0, 0.0])
    >>> gi, e = associate_interpolated(gt, est, max_gap=1.0)
    >>> gi.tolist(), e.positions[:, 0].tolist()
    ([0, 1, 2], [0.0, 1.0, 2.0])
    """
    if not np.isfinite(offset):
        raise TrajectoryError(f"offset must be finite, not {offset!r}")
    query = gt.timestamps - offset
    placed, _, pos, quat = interpolate_poses(est, query, max_gap=max_gap, stamp_tol=stamp_tol)
    gi = np.flatnonzero(placed)
    if gi.shape[0] == 0:
        raise TrajectoryError(
            f"{est.source}: no ground-truth pose of {gt.source} falls inside the estimate "
            f"(offset {offset} s, max_gap {max_gap} s; estimate {est.timestamps[0]:.6f}.."
            f"{est.timestamps[-1]:.6f} s, ground truth {gt.timestamps[0]:.6f}.."
            f"{gt.timestamps[-1]:.6f} s)"
        )
    est_at = Trajectory._from_checked(
        np.ascontiguousarray(query[gi]), np.ascontiguousarray(pos[gi]),
        np.ascontiguousarray(quat[gi]), source=est.source, meta=dict(est.meta))
    return gi, est_at


def evenly_spread(n: int, most: int) -> np.ndarray:
    """At most ``most`` of the indices ``0 .. n - 1``, evenly spread: all of them when
    ``n <= most``, else ``round(linspace(0, n - 1, most))`` (half to even) without
    duplicates (docs/spec.md 7c, 7e).

    Examples
    --------
    >>> evenly_spread(10, 4).tolist(), evenly_spread(3, 4).tolist()
    ([0, 3, 6, 9], [0, 1, 2])
    """
    if n <= most:
        return np.arange(n, dtype=np.int64)
    return np.unique(np.linspace(0, n - 1, most).round().astype(np.int64))
