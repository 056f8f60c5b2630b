"""How far one trajectory travels against another over the same time (docs/spec.md 7d).

A scan matcher that cannot see the motion along a corridor (docs/spec.md 7c) reports too
little of it: the corridor comes out short, and the map still agrees with its own scans. Its
trajectory shows it: over the same stretches of time it travels less than the trajectory of
a program that followed the odometry there. :func:`travel_ratio` measures that between two
estimates of one recording (on one clock); the verdict uses it only where the recording's
scans see walls in one direction (docs/spec.md section 9).

The comparison is between estimates, never against the odometry: the odometry's own scale
error enters every program that follows it alike.
"""

from __future__ import annotations

import math

import numpy as np

from slamq.errors import TrajectoryError
from slamq.metrics.sync import interpolate_poses
from slamq.models import Trajectory

__all__ = ["WINDOW_S", "travel_ratio"]

#: Seconds per window.
WINDOW_S = 10.0


def travel_ratio(a: Trajectory, b: Trajectory, *, window: float = WINDOW_S) -> float:
    """The distance ``a`` travels over windows of ``window`` seconds, over the distance
    ``b`` travels over the same windows.

    Both are placed at the timestamps of the one with fewer poses (``a`` on a tie) within
    the time both cover (the other interpolated, :func:`slamq.metrics.sync.interpolate_poses`
    with its default gap); from the first of those times, a window ends at the first time
    at least ``window`` seconds after it began. The ratio is the sum of ``a``'s chords
    (start to end of each window) over ``b``'s: under 1 when ``a`` travels less. Chords of
    windows of time, so that neither a trajectory's jitter between poses nor a matcher's
    stick-and-jump moves a window's ends.

    Parameters
    ----------
    a, b : Trajectory
        Two estimates of one recording, on one clock (seconds), in any frames.
    window : float, default :data:`WINDOW_S`
        Seconds per window (> 0).

    Returns
    -------
    float
        NaN when fewer than two whole windows are covered by both, or ``b`` travels no
        distance over them.

    Raises
    ------
    slamq.TrajectoryError
        ``window`` is not a positive finite number.

    Examples
    --------
    >>> import numpy as np
    >>> from slamq import Trajectory
    >>> t = np.arange(0.0, 60.0, 0.1)
    >>> a = Trajectory.from_xy_yaw(t, 0.5 * t, np.zeros_like(t), np.zeros_like(t))
    >>> b = Trajectory.from_xy_yaw(t, 0.5 * t * 1.05, np.zeros_like(t), np.zeros_like(t))
    >>> round(travel_ratio(a, b), 4), round(travel_ratio(b, a), 4)
    (0.9524, 1.05)
    >>> round(travel_ratio(a, a.subset(np.arange(0, 600, 7))), 6)  # other stamps, same path
    1.0
    """
    if not (isinstance(window, (int, float)) and math.isfinite(window) and window > 0):
        raise TrajectoryError(f"travel window {window!r}: must be a positive number of "
                              "seconds")
    ta, tb = a.timestamps, b.timestamps
    if len(ta) < 2 or len(tb) < 2:
        return math.nan
    lo, hi = max(ta[0], tb[0]), min(ta[-1], tb[-1])
    sparse = ta if len(ta) <= len(tb) else tb
    times = sparse[(sparse >= lo) & (sparse <= hi)]
    if times.size < 3:
        return math.nan
    oka, _, pa, _ = interpolate_poses(a, times)
    okb, _, pb, _ = interpolate_poses(b, times)
    both = oka & okb
    pa, pb = pa[both, :2], pb[both, :2]
    if len(pa) < 3:
        return math.nan
    when = times[both]
    cuts = [0]
    for i in range(1, len(when)):
        if when[i] - when[cuts[-1]] >= window:
            cuts.append(i)
    if len(cuts) < 3:
        return math.nan
    k = np.asarray(cuts)
    chord_a = float(np.hypot(*np.diff(pa[k], axis=0).T).sum())
    chord_b = float(np.hypot(*np.diff(pb[k], axis=0).T).sum())
    return chord_a / chord_b if chord_b > 0 else math.nan
