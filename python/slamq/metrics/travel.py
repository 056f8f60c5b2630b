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

__all__ = ["WINDOW_S", "corridor_travel_ratio", "travel_ratio"]

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
    windows = _windows(a, b, window)
    if windows is None:
        return math.nan
    _, chord_a, chord_b = windows
    return _ratio(chord_a, chord_b)


def corridor_travel_ratio(a: Trajectory, b: Trajectory, stamps: np.ndarray,
                          ratios: np.ndarray, *, window: float = WINDOW_S) -> float:
    """:func:`travel_ratio` along the recording's corridors over the same ratio elsewhere
    (docs/spec.md 7d): how much less ``a`` travels than ``b`` where the scans see walls in
    one direction only, beyond what it travels less everywhere.

    The windows are :func:`travel_ratio`'s. A window is *one-directional* when at least
    half of the scored scans stamped within it (its begin included, its end not) that
    have a ratio are under :data:`slamq.metrics.degeneracy.DEGENERATE_RATIO`,
    *two-directional* when fewer are; a window without a scored scan with a ratio is left
    out. r1 is ``a``'s chords over ``b``'s on the one-directional windows, r2 on the
    two-directional ones (each NaN with fewer than two windows or no chord of ``b``); the
    result is r1 / r2, and :func:`travel_ratio` where either is NaN. A difference of scale
    between the two paths (one follows the odometry's scale error, the other corrects it)
    is the same in both kinds of window and cancels; a scan matcher that loses travel
    along corridors loses it in the one-directional windows only.

    Parameters
    ----------
    a, b : Trajectory
        Two estimates of one recording, on one clock (seconds), in any frames.
    stamps : numpy.ndarray
        ``(n,)`` the scored scans' times, on the trajectories' clock
        (:attr:`slamq.models.ScanDegeneracy.stamps`).
    ratios : numpy.ndarray
        ``(n,)`` their ratios (:attr:`slamq.models.ScanDegeneracy.ratios`; NaN: none).
    window : float, default :data:`WINDOW_S`
        Seconds per window (> 0).

    Returns
    -------
    float
        Under 1 when ``a`` travels less along the corridors than elsewhere, against ``b``.

    Raises
    ------
    slamq.TrajectoryError
        ``window`` is not a positive finite number, or ``stamps`` and ``ratios`` differ
        in length.

    Examples
    --------
    A corridor from 30 s to 60 s: ``a`` travels 10% less than ``b`` there and the same
    elsewhere; ``c`` travels 3% less everywhere (a difference of scale).

    >>> import numpy as np
    >>> from slamq import Trajectory
    >>> t = np.arange(0.0, 90.0, 0.1)
    >>> b = Trajectory.from_xy_yaw(t, 0.5 * t, np.zeros_like(t), np.zeros_like(t))
    >>> speed = np.where((t >= 30) & (t < 60), 0.45, 0.5)
    >>> x = np.concatenate([[0.0], np.cumsum(speed[:-1] * 0.1)])
    >>> a = Trajectory.from_xy_yaw(t, x, np.zeros_like(t), np.zeros_like(t))
    >>> c = Trajectory.from_xy_yaw(t, 0.485 * t, np.zeros_like(t), np.zeros_like(t))
    >>> stamps = np.arange(0.0, 90.0, 1.0)
    >>> ratios = np.where((stamps >= 30) & (stamps < 60), 0.02, 0.8)
    >>> round(corridor_travel_ratio(a, b, stamps, ratios), 3), round(travel_ratio(a, b), 3)
    (0.9, 0.963)
    >>> round(corridor_travel_ratio(c, b, stamps, ratios), 3), round(travel_ratio(c, b), 3)
    (1.0, 0.97)
    """
    from slamq.metrics.degeneracy import DEGENERATE_RATIO

    stamps = np.asarray(stamps, dtype=np.float64).ravel()
    ratios = np.asarray(ratios, dtype=np.float64).ravel()
    if stamps.shape != ratios.shape:
        raise TrajectoryError(f"corridor travel: {stamps.size} scan stamps but "
                              f"{ratios.size} ratios")
    windows = _windows(a, b, window)
    if windows is None:
        return math.nan
    bounds, chord_a, chord_b = windows
    whole = _ratio(chord_a, chord_b)
    has = np.isfinite(ratios)
    st, low = stamps[has], ratios[has] < DEGENERATE_RATIO
    kind = np.full(chord_a.size, -1)  # -1: no scored scan; 1: one-directional; 0: two
    for i in range(chord_a.size):
        inside = (st >= bounds[i]) & (st < bounds[i + 1])
        if inside.any():
            kind[i] = int(2 * low[inside].sum() >= inside.sum())
    one, two = kind == 1, kind == 0
    r1 = _ratio(chord_a[one], chord_b[one]) if one.sum() >= 2 else math.nan
    r2 = _ratio(chord_a[two], chord_b[two]) if two.sum() >= 2 else math.nan
    if not (math.isfinite(r1) and math.isfinite(r2)) or r2 <= 0:
        return whole
    return r1 / r2


def _ratio(chord_a: np.ndarray, chord_b: np.ndarray) -> float:
    """The sum of ``chord_a`` over the sum of ``chord_b`` (NaN when that is 0)."""
    sum_b = float(chord_b.sum())
    return float(chord_a.sum()) / sum_b if sum_b > 0 else math.nan


def _windows(a: Trajectory, b: Trajectory, window: float
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """The windows of :func:`travel_ratio`: their bounds (times, ``(k + 1,)``) and each
    window's chord of ``a`` and of ``b`` (``(k,)``); None with fewer than two windows."""
    if not (isinstance(window, (int, float)) and math.isfinite(window) and window > 0):
        raise TrajectoryError(f"travel window {window!r}: must be a positive number of "
                              "seconds")
    ta, tb = a.timestamps, b.timestamps
    if len(ta) < 2 or len(tb) < 2:
        return None
    lo, hi = max(ta[0], tb[0]), min(ta[-1], tb[-1])
    sparse = ta if len(ta) <= len(tb) else tb
    times = sparse[(sparse >= lo) & (sparse <= hi)]
    if times.size < 3:
        return None
    oka, _, pa, _ = interpolate_poses(a, times)
    okb, _, pb, _ = interpolate_poses(b, times)
    both = oka & okb
    pa, pb = pa[both, :2], pb[both, :2]
    if len(pa) < 3:
        return None
    when = times[both]
    cuts = [0]
    for i in range(1, len(when)):
        if when[i] - when[cuts[-1]] >= window:
            cuts.append(i)
    if len(cuts) < 3:
        return None
    k = np.asarray(cuts)
    return (when[k], np.hypot(*np.diff(pa[k], axis=0).T),
            np.hypot(*np.diff(pb[k], axis=0).T))
