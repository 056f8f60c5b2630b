"""Association of two trajectories by nearest timestamp (evo's ``associate_trajectories``).

The rule is evo's, vectorised: the trajectory with fewer poses (the estimate when both
have as many) is the "short" one; each of its poses is matched with the nearest pose of
the long one whose (offset) timestamp is within ``max_dt``; a tie goes to the earlier
pose. A long-trajectory pose may be matched more than once; short poses without a match
are dropped. ``offset`` is added to the estimate's timestamps.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from slamq import native
from slamq.errors import TrajectoryError
from slamq.models.trajectory import Trajectory
from slamq.params import SETTINGS

__all__ = ["matching_indices", "matching_indices_numpy", "associate"]


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
