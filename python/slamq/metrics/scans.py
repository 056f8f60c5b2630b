"""A map against its own laser scans (docs/spec.md section 7b).

Each scan, placed at the map's estimated pose, is cast into the map: a beam that ends on or
near a wall of the map is a *hit*; a beam that passes through a wall of the map before its
end is a *free-space violation* (the laser saw through a wall the map has); a violation is a
*crossing* when the beam then comes out into known free space clear of every wall before its
end (it saw through the wall, not along it: a beam grazing a wall drawn a cell too thick is
a violation, not a crossing). A map built from drifted poses, or with a missing, doubled or
ghost wall, disagrees with its own data.
This needs one map and its scans only, no ground truth and no other map.

- :func:`scan_consistency`: the Rust core (``rust/src/scans.rs``), scans in parallel.
- :func:`scan_consistency_reference`: its plain numpy twin, the same walk written out
  (slow; for tests and benchmarks); both give the same integers.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from slamq import native
from slamq.errors import SlamqError
from slamq.metrics.relations import _yaw
from slamq.metrics.sync import MAX_GAP, STAMP_TOL, interpolate_poses
from slamq.models import OccupancyMap, Trajectory
from slamq.models.scans import COUNTS, ScanConsistency, Scans
from slamq.params import check_threads
from slamq.synth.sensors import walk_start

__all__ = ["SCAN_TOLERANCE", "scan_consistency", "scan_consistency_reference"]

#: Default tolerance, metres: a beam ending this close to a wall cell hits it, and a wall
#: cell entered less than this before a beam's end is no violation (range noise, walls a
#: cell thick).
SCAN_TOLERANCE = 0.1

#: Bits of a cell's state in the reference walk (as in rust/src/scans.rs).
_OCCUPIED, _UNKNOWN, _NEAR, _OUTSIDE = 1, 2, 4, 8


def _prepare(map: OccupancyMap, scans: Scans, poses: Any, scan_tolerance: float,
             occupied_threshold: float, max_gap: float, stamp_tol: float
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Checked inputs: which scans have a pose, their laser poses ``(K, 3)`` and ranges."""
    if not isinstance(map, OccupancyMap):
        raise SlamqError(f"map must be an OccupancyMap, got {type(map).__name__}")
    if not isinstance(scans, Scans):
        raise SlamqError(f"scans must be a Scans, got {type(scans).__name__}")
    if map.resolution is None:
        raise SlamqError(f"{map.source}: scan consistency needs the map's resolution")
    tol = float(scan_tolerance)
    if not (math.isfinite(tol) and tol > 0):
        raise SlamqError(f"scan_tolerance must be a positive number of metres, got {tol}")
    if not (0.0 <= float(occupied_threshold) < 1.0):
        raise SlamqError(f"occupied_threshold must be in [0, 1), got {occupied_threshold}")
    return place(scans, poses, max_gap, stamp_tol)


def robot_poses(scans: Scans, poses: Any, max_gap: float = MAX_GAP,
                stamp_tol: float = STAMP_TOL) -> np.ndarray:
    """The robot's ``(N, 3)`` ``(x, y, yaw)`` at each of ``scans``, NaN where ``poses`` does
    not place it (SPEC 7b: a :class:`Trajectory` by
    :func:`~slamq.metrics.sync.interpolate_poses`, or one ``(x, y, yaw)`` per scan, rows
    with a NaN left out).

    Examples
    --------
    >>> s = Scans(np.arange(3.0), [0.0], np.ones((3, 1)), 10.0)
    >>> robot_poses(s, [[0, 0, 0], [1, np.nan, 0], [2, 0, 0]])[:, 0].tolist()
    [0.0, nan, 2.0]
    """
    n = len(scans)
    if isinstance(poses, Trajectory):
        placed, _, pos, quat = interpolate_poses(poses, scans.stamps, max_gap=max_gap,
                                                 stamp_tol=stamp_tol)
        robot = np.full((n, 3), np.nan)
        robot[placed] = np.column_stack([pos[placed, 0], pos[placed, 1],
                                         _yaw(quat[placed])])
        return robot
    robot = np.array(poses, dtype=np.float64)
    if robot.shape != (n, 3):
        raise SlamqError(f"{scans.source}: poses must be a Trajectory or an ({n}, 3) "
                         f"array of (x, y, yaw), one per scan; got shape {robot.shape}")
    robot[~np.isfinite(robot).all(axis=1)] = np.nan
    return robot


def place(scans: Scans, poses: Any, max_gap: float = MAX_GAP, stamp_tol: float = STAMP_TOL
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Which of ``scans`` ``poses`` places (:func:`robot_poses`), the laser's ``(K, 3)``
    world poses at the placed ones, and their ``(K, B)`` ranges."""
    robot = robot_poses(scans, poses, max_gap, stamp_tol)
    placed = np.isfinite(robot).all(axis=1)
    robot = robot[placed]
    return placed, scans.laser_poses(robot), np.ascontiguousarray(scans.ranges[placed])


def _result(map: OccupancyMap, placed: np.ndarray, counts: np.ndarray, grid: np.ndarray,
            crossed: np.ndarray, scan_tolerance: float, occupied_threshold: float
            ) -> ScanConsistency:
    full = np.zeros((placed.shape[0], len(COUNTS)), np.int64)
    full[placed] = counts
    return ScanConsistency(full, placed, grid, float(scan_tolerance),
                           float(occupied_threshold), source=map.source, crossing_grid=crossed)


def scan_consistency(map: OccupancyMap, scans: Scans, poses: Trajectory | Any, *,
                     scan_tolerance: float = SCAN_TOLERANCE, occupied_threshold: float = 0.5,
                     max_gap: float = MAX_GAP, stamp_tol: float = STAMP_TOL,
                     threads: int | None = None) -> ScanConsistency:
    """Score ``map`` by how well its own ``scans``, placed at ``poses``, agree with it.

    Parameters
    ----------
    map : OccupancyMap
        The map (with a resolution).
    scans : Scans
        The laser scans the map was built from.
    poses : Trajectory or array_like
        The robot's estimated poses in the map's frame: a :class:`Trajectory` (placed at
        each scan's stamp by :func:`slamq.metrics.sync.interpolate_poses`: the pose at that
        stamp within ``stamp_tol``, else interpolated between poses at most ``max_gap``
        apart; other scans are left out), or an ``(N, 3)`` array of ``(x, y, yaw)``, one
        per scan (rows with a NaN are left out).
    scan_tolerance : float
        Metres (SPEC 7b).
    occupied_threshold : float
        A known cell is occupied when ``(255 - v) / 255`` is above it.
    max_gap, stamp_tol : float
        Seconds, for a :class:`Trajectory`.
    threads : int, optional
        Worker threads (None: every core); the result does not depend on it.

    Returns
    -------
    ScanConsistency

    Examples
    --------
    >>> import numpy as np
    >>> from slamq import OccupancyMap
    >>> v = np.full((10, 10), 254, np.uint8); v[:, 7] = 0     # a wall at x in [0.7, 0.8]
    >>> m = OccupancyMap(v, np.zeros_like(v, bool), 0.1)
    >>> s = Scans([0.0, 1.0], [0.0], [[0.46], [0.9]], 20.0)    # the second sees through it
    >>> c = scan_consistency(m, s, [[0.25, 0.55, 0.0], [0.25, 0.55, 0.0]])
    >>> c.hit_shares.tolist(), c.violation_shares.tolist(), int(c.violation_grid[4, 7])
    ([1.0, 0.0], [0.0, 1.0], 1)
    """
    placed, laser, ranges = _prepare(map, scans, poses, scan_tolerance, occupied_threshold,
                                     max_gap, stamp_tol)
    n_threads = 0 if threads is None else check_threads(threads)
    try:
        counts, grid, crossed = native.scan_consistency(
            map.values, map.unknown, float(map.resolution), tuple(map.origin),
            float(occupied_threshold), float(scan_tolerance), laser, scans.angles, ranges,
            scans.min_range, scans.max_range, n_threads)
    except ValueError as exc:
        raise SlamqError(f"{map.source} with {scans.source}: {exc}") from None
    return _result(map, placed, counts, grid, crossed, scan_tolerance, occupied_threshold)


def scan_consistency_reference(map: OccupancyMap, scans: Scans, poses: Trajectory | Any, *,
                               scan_tolerance: float = SCAN_TOLERANCE,
                               occupied_threshold: float = 0.5, max_gap: float = MAX_GAP,
                               stamp_tol: float = STAMP_TOL) -> ScanConsistency:
    """:func:`scan_consistency` in plain numpy, SPEC 7b written out: the same integers.

    The trigonometry is :func:`math.cos` / :func:`math.sin` per beam (the C library's, as
    the Rust core's), the rest the same float64 operations in the same order.

    Examples
    --------
    >>> import numpy as np
    >>> from slamq import OccupancyMap
    >>> v = np.full((10, 10), 254, np.uint8); v[:, 7] = 0
    >>> m = OccupancyMap(v, np.zeros_like(v, bool), 0.1)
    >>> s = Scans([0.0], [0.0, 0.1, np.pi], [[0.46, 0.9, 0.2]], 20.0)
    >>> scan_consistency_reference(m, s, [[0.25, 0.55, 0.0]]).counts.tolist()
    [[3, 1, 1, 0, 1, 1, 1]]
    """
    placed, laser, ranges = _prepare(map, scans, poses, scan_tolerance, occupied_threshold,
                                     max_gap, stamp_tol)
    h, w = map.shape
    res = float(map.resolution)  # type: ignore[arg-type]
    ox0, oy0, oyaw = map.origin
    tol = float(scan_tolerance) / res
    p = (255.0 - np.arange(256, dtype=np.float64)) / 255.0 > float(occupied_threshold)
    occupied = p[map.values] & ~map.unknown
    # the state of every cell, with a ring of OUTSIDE around the grid
    # the disc of the tolerance: offsets with di^2 + dj^2 <= tol^2
    reach = math.floor(tol)
    di, dj = np.mgrid[-reach:reach + 1, -reach:reach + 1]
    inside = (di * di + dj * dj).astype(np.float64) <= tol * tol
    di, dj = di[inside], dj[inside]
    padded = np.zeros((h + 2 * reach, w + 2 * reach), bool)
    padded[reach:reach + h, reach:reach + w] = occupied
    near_wall = np.zeros((h, w), bool)
    for a_, b_ in zip(di, dj):
        near_wall |= padded[reach + a_:reach + a_ + h, reach + b_:reach + b_ + w]
    state = np.full((h + 2, w + 2), _OUTSIDE, np.uint8)
    state[1:-1, 1:-1] = (np.where(map.unknown, _UNKNOWN, np.where(occupied, _OCCUPIED, 0))
                         | np.where(near_wall, _NEAR, 0)).astype(np.uint8)
    flat = state.ravel()
    c, s = math.cos(oyaw), math.sin(oyaw)
    counts = np.zeros((len(laser), len(COUNTS)), np.int64)
    grid = np.zeros((h, w), np.uint32)
    crossing_grid = np.zeros((h, w), np.uint32)
    for k, (x, y, yaw) in enumerate(laser):
        r = ranges[k]
        valid = np.isfinite(r) & (r > scans.min_range) & (r < scans.max_range)
        r = r[valid]
        counts[k, 0] = r.shape[0]
        if r.shape[0] == 0:
            continue
        wx, wy = x - ox0, y - oy0
        ox = (c * wx + s * wy) / res
        oy = (c * wy - s * wx) / res
        a = (yaw + scans.angles[valid]) - oyaw
        dx = np.array([math.cos(v) for v in a])
        dy = np.array([math.sin(v) for v in a])
        length = r / res
        ex, ey = ox + length * dx, oy + length * dy
        fx, fy = np.floor(ex), np.floor(ey)
        on = (fx >= 0) & (fx < w) & (fy >= 0) & (fy < h)
        col = np.where(on, fx, 0).astype(np.int64)
        row = h - 1 - np.where(on, fy, 0).astype(np.int64)
        near = on & near_wall[row, col]
        unknown = on & ~near & map.unknown[row, col]
        counts[k, 1] = np.count_nonzero(near)
        counts[k, 3] = np.count_nonzero(unknown)
        counts[k, 2] = np.count_nonzero(on & ~near & ~unknown)
        counts[k, 4] = np.count_nonzero(~on)
        cells, beams, crossed = _walk(flat, h, w, ox, oy, dx, dy, length - tol)
        counts[k, 5] = np.unique(beams).shape[0]
        counts[k, 6] = np.count_nonzero(crossed)
        np.add.at(grid.ravel(), cells, 1)
        np.add.at(crossing_grid.ravel(), cells[crossed[beams]], 1)
    return _result(map, placed, counts, grid, crossing_grid, scan_tolerance,
                   occupied_threshold)


def _walk(flat: np.ndarray, h: int, w: int, ox: float, oy: float, dx: np.ndarray,
          dy: np.ndarray, t_end: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The occupied cells (row-major index on the unpadded grid) each beam from ``(ox, oy)``
    (grid units) enters at a parameter ``t < t_end``, the beam of each, and per beam whether
    it entered a known free cell clear of every wall after an occupied one (a crossing)."""
    t0, alive, idx, tx, tdx, sx, ty, tdy, sy = walk_start(h, w, ox, oy, dx, dy, t_end,
                                                          t_end > 0.0)
    alive &= t0 < t_end
    pw = w + 2
    cells: list[np.ndarray] = []
    beams: list[np.ndarray] = []
    seen = np.zeros(dx.shape[0], bool)
    crossed = np.zeros(dx.shape[0], bool)
    live = np.flatnonzero(alive)
    while live.size:
        v = flat[idx[live]]
        live = live[(v & _OUTSIDE) == 0]
        v = flat[idx[live]]
        clear = live[v == 0]
        crossed[clear] |= seen[clear]
        hit = live[(v & _OCCUPIED) != 0]
        seen[hit] = True
        if hit.size:
            row, col = idx[hit] // pw - 1, idx[hit] % pw - 1
            cells.append(row * w + col)
            beams.append(hit)
        step_x = tx[live] < ty[live]
        t = np.where(step_x, tx[live], ty[live])
        keep = t < t_end[live]
        live, step_x = live[keep], step_x[keep]
        tx[live] += np.where(step_x, tdx[live], 0.0)
        ty[live] += np.where(step_x, 0.0, tdy[live])
        idx[live] += np.where(step_x, sx[live], sy[live])
    if not cells:
        return np.zeros(0, np.int64), np.zeros(0, np.int64), crossed
    return np.concatenate(cells), np.concatenate(beams), crossed
