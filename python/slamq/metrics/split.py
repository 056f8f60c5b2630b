"""A trajectory against its own scans, split in time (docs/spec.md section 7e).

The scans a trajectory places are cut into two halves in time; each half is drawn as a map
at the trajectory's poses, and the other half's scans are scored against it by section 7b
(:func:`slamq.metrics.scans.scan_consistency`). Where the trajectory is wrong, a wall one
half draws is crossed by the other half's beams; a map drawn from all the scans would let
the right poses outvote the wrong ones, and the SLAM program's own map carries its drawing
convention. This figure reads neither: only the scans and the trajectory.

- :func:`scan_split`: the Rust core (``rust/src/split.rs``), the two halves in parallel.
- :func:`scan_split_reference`: its plain numpy twin, the same walks and fills written out
  (slow; for tests and benchmarks); both give the same maps and the same integers.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from slamq import native
from slamq.errors import SlamqError
from slamq.metrics.scans import (
    SCAN_TOLERANCE,
    place,
    robot_poses,
    scan_consistency_reference,
)
from slamq.metrics.sync import MAX_GAP, STAMP_TOL, evenly_spread
from slamq.models import OccupancyMap, Trajectory
from slamq.models.scans import Scans, ScanSplit
from slamq.params import check_threads

__all__ = ["LOCAL_MIN_SCANS", "LOCAL_SCANS", "LOCAL_WINDOW", "LOCAL_WINDOWS", "MARGIN",
           "MAX_DRAW", "MAX_TEST", "OCCUPIED_SHARE", "RESOLUTION", "local_split",
           "local_split_reference", "local_windows", "scan_split", "scan_split_reference"]

#: The drawn maps' cell size, metres.
RESOLUTION = 0.05
#: A drawn cell is occupied when hit and its hits are at least this share of its visits.
OCCUPIED_SHARE = 0.5
#: Grid around the drawn scans, metres.
MARGIN = 1.0
#: Scans each half draws at most, and scans of each half scored at most (evenly spread).
MAX_DRAW = 3000
MAX_TEST = 500
#: The most cells a drawn map may have (``rust/src/split.rs``'s ``MAX_CELLS``).
MAX_CELLS = 1 << 26

_FREE, _OCCUPIED, _UNKNOWN = 254, 0, 205


def _prepare(scans: Scans, poses: Any, resolution: float, occupied_share: float,
             scan_tolerance: float, max_draw: int, max_test: int, max_gap: float,
             stamp_tol: float) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                        list[tuple[np.ndarray, np.ndarray]]]:
    """Checked inputs: which scans are placed, their laser poses and ranges, and per half
    ``(drawn, tested)`` as indices into the placed scans."""
    if not isinstance(scans, Scans):
        raise SlamqError(f"scans must be a Scans, got {type(scans).__name__}")
    res, share, tol = float(resolution), float(occupied_share), float(scan_tolerance)
    if not (math.isfinite(res) and res > 0):
        raise SlamqError(f"resolution must be a positive number of metres, got {res}")
    if not (0.0 < share <= 1.0):
        raise SlamqError(f"occupied_share must be in (0, 1], got {share}")
    if not (math.isfinite(tol) and tol > 0):
        raise SlamqError(f"scan_tolerance must be a positive number of metres, got {tol}")
    if not (1 <= max_draw <= 65534 and max_test >= 1):
        raise SlamqError(f"need 1 <= max_draw <= 65534 and max_test >= 1, got {max_draw} "
                         f"and {max_test}")
    placed, laser, ranges = place(scans, poses, max_gap, stamp_tol)
    k = laser.shape[0]
    if k < 2:
        raise SlamqError(f"{scans.source}: the poses place {k} of {len(scans)} scans; a "
                         f"split needs at least 2")
    first, second = np.array_split(np.arange(k, dtype=np.int64), 2)
    halves = [(first[evenly_spread(first.size, max_draw)],
               second[evenly_spread(second.size, max_test)]),
              (second[evenly_spread(second.size, max_draw)],
               first[evenly_spread(first.size, max_test)])]
    return placed, laser, ranges, halves


def _result(scans: Scans, placed: np.ndarray, halves: list[tuple[np.ndarray, np.ndarray]],
            counts: tuple[np.ndarray, np.ndarray], maps: tuple[OccupancyMap, OccupancyMap],
            resolution: float, occupied_share: float, scan_tolerance: float) -> ScanSplit:
    where = np.flatnonzero(placed)
    return ScanSplit(counts=counts, drawn=(where[halves[0][0]], where[halves[1][0]]),
                     tested=(where[halves[0][1]], where[halves[1][1]]), maps=maps,
                     placed=placed, resolution=float(resolution),
                     occupied_share=float(occupied_share), tolerance=float(scan_tolerance),
                     source=scans.source)


def scan_split(scans: Scans, poses: Trajectory | Any, *, resolution: float = RESOLUTION,
               occupied_share: float = OCCUPIED_SHARE,
               scan_tolerance: float = SCAN_TOLERANCE, max_draw: int = MAX_DRAW,
               max_test: int = MAX_TEST, max_gap: float = MAX_GAP,
               stamp_tol: float = STAMP_TOL, threads: int | None = None) -> ScanSplit:
    """Score a trajectory against its own ``scans``, split in time (SPEC 7e).

    Parameters
    ----------
    scans : Scans
        The laser scans the trajectory was estimated from, in time order.
    poses : Trajectory or array_like
        The robot's estimated poses: a :class:`Trajectory` (placed at each scan's stamp by
        :func:`slamq.metrics.sync.interpolate_poses`), or an ``(N, 3)`` array of
        ``(x, y, yaw)``, one per scan (rows with a NaN are left out).
    resolution : float
        The drawn maps' metres per cell.
    occupied_share : float
        A drawn cell is occupied when its hits are at least this share of its visits.
    scan_tolerance : float
        Metres (SPEC 7b).
    max_draw, max_test : int
        Scans each half draws and scans of each half scored, at most (evenly spread).
    max_gap, stamp_tol : float
        Seconds, for a :class:`Trajectory`.
    threads : int, optional
        Worker threads (None: every core); the result does not depend on it.

    Returns
    -------
    ScanSplit
        ``crossing_share``: the figure (0 when the halves never see through each other's
        walls).

    Raises
    ------
    SlamqError
        Bad parameters, fewer than 2 placed scans, or scans spanning more than
        :data:`MAX_CELLS` cells.

    Examples
    --------
    >>> import numpy as np
    >>> a = np.array([0.0, np.pi])                   # a laser looking both ways
    >>> s = Scans(np.arange(10.0), a, np.full((10, 2), 1.03), 10.0)
    >>> right = np.zeros((10, 3)); right[:, 1] = 0.05
    >>> scan_split(s, right).crossing_share
    0.0
    >>> wrong = right.copy(); wrong[5:, 0] = 1.5        # the second half placed 1.5 m off
    >>> scan_split(s, wrong).crossing_share
    0.5
    """
    placed, laser, ranges, halves = _prepare(scans, poses, resolution, occupied_share,
                                             scan_tolerance, max_draw, max_test, max_gap,
                                             stamp_tol)
    n_threads = 0 if threads is None else check_threads(threads)
    try:
        counts, one, two, (x0, y0) = native.scan_split(
            laser, scans.angles, ranges, scans.min_range, scans.max_range, *halves[0],
            *halves[1], float(resolution), MARGIN, float(occupied_share),
            float(scan_tolerance), n_threads)
    except ValueError as exc:
        raise SlamqError(f"{scans.source}: {exc}") from None
    maps = tuple(OccupancyMap(v, u, float(resolution), (x0, y0, 0.0),
                              source=f"{scans.source} (half {i + 1})")
                 for i, (v, u) in enumerate((one, two)))
    return _result(scans, placed, halves, counts, maps,  # type: ignore[arg-type]
                   resolution, occupied_share, scan_tolerance)


def _frame(laser: np.ndarray, angles: np.ndarray, ranges: np.ndarray, valid: np.ndarray,
           drawn: np.ndarray, resolution: float, source: str
           ) -> tuple[int, int, float, float]:
    """``(height, width, x0, y0)``: the grid around the drawn scans' lasers and ends."""
    xs, ys = [laser[drawn, 0]], [laser[drawn, 1]]
    for k in drawn:
        x, y, yaw = laser[k]
        a = yaw + angles[valid[k]]
        r = ranges[k][valid[k]]
        xs.append(x + r * np.array([math.cos(v) for v in a]))
        ys.append(y + r * np.array([math.sin(v) for v in a]))
    x, y = np.concatenate(xs), np.concatenate(ys)
    x0, y0 = float(x.min()) - MARGIN, float(y.min()) - MARGIN
    width = max(math.ceil((float(x.max()) + MARGIN - x0) / resolution), 1)
    height = max(math.ceil((float(y.max()) + MARGIN - y0) / resolution), 1)
    if width * height > MAX_CELLS:
        raise SlamqError(f"{source}: the scans span more than {MAX_CELLS} cells at "
                         f"{resolution} m")
    return height, width, x0, y0


def _fill(vx: np.ndarray, vy: np.ndarray, h: int, w: int) -> np.ndarray:
    """The cells (row-major, row 0 at the top) of an ``h x w`` grid whose centre lies in
    the closed polygon ``(vx, vy)`` (grid units, y up) by the even-odd rule, as
    ``rust/src/split.rs``'s ``fill``."""
    px, py = vx, vy
    qx, qy = np.roll(vx, -1), np.roll(vy, -1)
    e = np.flatnonzero(py != qy)
    px, py, qx, qy = px[e], py[e], qx[e], qy[e]
    lo, hi = np.minimum(py, qy), np.maximum(py, qy)
    r0 = np.maximum(np.ceil(lo - 0.5).astype(np.int64), 0)
    r1 = np.minimum(np.ceil(hi - 0.5).astype(np.int64), h)
    count = np.maximum(r1 - r0, 0)
    edge = np.repeat(np.arange(e.size), count)
    row = r0[edge] + (np.arange(edge.size) - np.repeat(np.cumsum(count) - count, count))
    yc = row.astype(np.float64) + 0.5
    x = px[edge] + (yc - py[edge]) * (qx[edge] - px[edge]) / (qy[edge] - py[edge])
    order = np.lexsort((x, row))
    row, x = row[order], x[order]
    y0, x0, x1 = row[0::2], x[0::2], x[1::2]
    c0 = np.maximum(np.ceil(x0 - 0.5).astype(np.int64), 0)
    c1 = np.minimum(np.floor(x1 - 0.5).astype(np.int64), w - 1)
    n = np.maximum(c1 - c0 + 1, 0)
    at = np.repeat(np.arange(n.size), n)
    col = c0[at] + (np.arange(at.size) - np.repeat(np.cumsum(n) - n, n))
    return (h - 1 - y0[at]) * w + col


def _draw(laser: np.ndarray, angles: np.ndarray, ranges: np.ndarray, valid: np.ndarray,
          drawn: np.ndarray, frame: tuple[int, int, float, float], resolution: float,
          occupied_share: float) -> tuple[np.ndarray, np.ndarray]:
    """The scans ``drawn`` drawn as a map (SPEC 7e): per scan, its beams walked and its
    polygon filled (:func:`_fill`), each cell counted once."""
    h, w, x0, y0 = frame
    hits = np.zeros(h * w, np.int64)
    visits = np.zeros(h * w, np.int64)
    for k in drawn:
        x, y, yaw = laser[k]
        r = ranges[k][valid[k]]
        if r.size == 0:
            continue
        ox, oy = (x - x0) / resolution, (y - y0) / resolution
        fx, fy = math.floor(ox), math.floor(oy)
        a = yaw + angles[valid[k]]
        dx = np.array([math.cos(v) for v in a])
        dy = np.array([math.sin(v) for v in a])
        length = r / resolution
        ex, ey = ox + length * dx, oy + length * dy
        ecol, ey_ = np.floor(ex).astype(np.int64), np.floor(ey).astype(np.int64)
        with np.errstate(divide="ignore", invalid="ignore"):
            tx = np.where(dx > 0, (fx + 1.0 - ox) / dx,
                          np.where(dx < 0, (fx - ox) / dx, np.inf))
            tdx = np.where(dx > 0, 1.0 / dx, np.where(dx < 0, -1.0 / dx, 0.0))
            ty = np.where(dy > 0, (fy + 1.0 - oy) / dy,
                          np.where(dy < 0, (fy - oy) / dy, np.inf))
            tdy = np.where(dy > 0, 1.0 / dy, np.where(dy < 0, -1.0 / dy, 0.0))
        sx = np.sign(dx).astype(np.int64)
        sy = np.sign(dy).astype(np.int64)
        col = np.full(r.size, fx, np.int64)
        row = np.full(r.size, fy, np.int64)  # counted up from the bottom
        seen: list[np.ndarray] = []
        live = np.flatnonzero((col != ecol) | (row != ey_))
        while live.size:
            live = live[(col[live] >= 0) & (col[live] < w) & (row[live] >= 0)
                        & (row[live] < h)]
            seen.append((h - 1 - row[live]) * w + col[live])
            step_x = tx[live] < ty[live]
            keep = np.where(step_x, tx[live], ty[live]) < length[live]
            live, step_x = live[keep], step_x[keep]
            tx[live] += np.where(step_x, tdx[live], 0.0)
            ty[live] += np.where(step_x, 0.0, tdy[live])
            col[live] += np.where(step_x, sx[live], 0)
            row[live] += np.where(step_x, 0, sy[live])
            live = live[(col[live] != ecol[live]) | (row[live] != ey_[live])]
        on = (ecol >= 0) & (ecol < w) & (ey_ >= 0) & (ey_ < h)
        ends = (h - 1 - ey_[on]) * w + ecol[on]
        # the scan's polygon: the laser, then each beam's end (the laser for invalid ones)
        vx = np.full(valid[k].size + 1, ox)
        vy = np.full(valid[k].size + 1, oy)
        vx[1:][valid[k]], vy[1:][valid[k]] = ex, ey
        if vx.size > 2:
            seen.append(_fill(vx, vy, h, w))
        visits[np.unique(np.concatenate([*seen, ends]))] += 1
        hits[np.unique(ends)] += 1
    occupied = (hits > 0) & (hits.astype(np.float64) >= occupied_share
                             * visits.astype(np.float64))
    values = np.where(occupied, _OCCUPIED, np.where(visits > 0, _FREE, _UNKNOWN))
    return values.astype(np.uint8).reshape(h, w), (visits == 0).reshape(h, w)


def scan_split_reference(scans: Scans, poses: Trajectory | Any, *,
                         resolution: float = RESOLUTION,
                         occupied_share: float = OCCUPIED_SHARE,
                         scan_tolerance: float = SCAN_TOLERANCE, max_draw: int = MAX_DRAW,
                         max_test: int = MAX_TEST, max_gap: float = MAX_GAP,
                         stamp_tol: float = STAMP_TOL) -> ScanSplit:
    """:func:`scan_split` in plain numpy, SPEC 7e written out: the same maps and integers.

    The trigonometry is :func:`math.cos` / :func:`math.sin` per beam (the C library's, as
    the Rust core's), the rest the same float64 operations in the same order; each half is
    scored by :func:`slamq.metrics.scans.scan_consistency_reference`.

    Examples
    --------
    >>> import numpy as np
    >>> s = Scans(np.arange(4.0), [0.0, np.pi], np.full((4, 2), 1.03), 10.0)
    >>> poses = np.array([[0, 0.05, 0]] * 2 + [[1.5, 0.05, 0]] * 2)
    >>> scan_split_reference(s, poses).crossing_shares.tolist()
    [0.5, 0.5]
    """
    placed, laser, ranges, halves = _prepare(scans, poses, resolution, occupied_share,
                                             scan_tolerance, max_draw, max_test, max_gap,
                                             stamp_tol)
    res = float(resolution)
    valid = np.isfinite(ranges) & (ranges > scans.min_range) & (ranges < scans.max_range)
    frame = _frame(laser, scans.angles, ranges, valid,
                   np.concatenate([halves[0][0], halves[1][0]]), res, scans.source)
    maps, counts = [], []
    for i, (drawn, tested) in enumerate(halves):
        values, unknown = _draw(laser, scans.angles, ranges, valid, drawn, frame, res,
                                float(occupied_share))
        m = OccupancyMap(values, unknown, res, (frame[2], frame[3], 0.0),
                         source=f"{scans.source} (half {i + 1})")
        part = Scans(np.arange(tested.size, dtype=np.float64), scans.angles, ranges[tested],
                     scans.max_range, min_range=scans.min_range)
        c = scan_consistency_reference(m, part, laser[tested], scan_tolerance=scan_tolerance,
                                       occupied_threshold=0.5)
        maps.append(m)
        counts.append(c.counts)
    return _result(scans, placed, halves, (counts[0], counts[1]), (maps[0], maps[1]),
                   resolution, occupied_share, scan_tolerance)


#: Local share (SPEC 7f): a window's travel at most, metres; its scans at most (evenly
#: thinned); the fewest scans a window scored has; the most windows scored (evenly spread).
LOCAL_WINDOW = 10.0
LOCAL_SCANS = 60
LOCAL_MIN_SCANS = 8
LOCAL_WINDOWS = 12


def local_windows(xy: np.ndarray, *, window: float = LOCAL_WINDOW,
                  max_scans: int = LOCAL_SCANS, min_scans: int = LOCAL_MIN_SCANS,
                  max_windows: int = LOCAL_WINDOWS) -> list[np.ndarray]:
    """The windows of SPEC 7f: indices into ``xy`` (``(K, 2)`` positions in time order),
    consecutive runs of at most ``window`` metres of travel, each thinned to at most
    ``max_scans``; those of fewer than ``min_scans`` left out; at most ``max_windows``,
    evenly spread.

    Examples
    --------
    >>> xy = np.column_stack([np.arange(0.0, 30.0, 0.5), np.zeros(60)])
    >>> [int(w[0]) for w in local_windows(xy)], [len(w) for w in local_windows(xy)]
    ([0, 21, 42], [21, 21, 18])
    """
    xy = np.asarray(xy, dtype=np.float64)
    if xy.ndim != 2 or xy.shape[1] != 2:
        raise SlamqError(f"positions must be (K, 2), got shape {xy.shape}")
    if not (math.isfinite(window) and window > 0 and max_scans >= 2 and min_scans >= 2
            and max_windows >= 1):
        raise SlamqError("need window > 0 m, max_scans >= 2, min_scans >= 2 and "
                         f"max_windows >= 1; got {window}, {max_scans}, {min_scans}, "
                         f"{max_windows}")
    travel = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(xy, axis=0).T))])
    out, start = [], 0
    while start < len(xy):
        end = int(np.searchsorted(travel, travel[start] + window, side="right"))
        if end - start >= min_scans:
            out.append(np.arange(start, end)[evenly_spread(end - start, max_scans)])
        start = end
    return [out[i] for i in evenly_spread(len(out), max_windows)]


def _local(split: Any, scans: Scans, poses: Trajectory | Any, window: float, max_scans: int,
           min_scans: int, max_windows: int, max_gap: float, stamp_tol: float,
           **kw: Any) -> np.ndarray:
    robot = robot_poses(scans, poses, max_gap, stamp_tol)
    where = np.flatnonzero(np.isfinite(robot).all(axis=1))
    shares = []
    for w in local_windows(robot[where, :2], window=window, max_scans=max_scans,
                           min_scans=min_scans, max_windows=max_windows):
        k = where[w]
        part = Scans(scans.stamps[k], scans.angles, scans.ranges[k], scans.max_range,
                     min_range=scans.min_range, offset=scans.offset, source=scans.source)
        shares.append(split(part, robot[k], **kw).crossing_share)
    return np.array(shares, dtype=np.float64)


def local_split(scans: Scans, poses: Trajectory | Any, *, window: float = LOCAL_WINDOW,
                max_scans: int = LOCAL_SCANS, min_scans: int = LOCAL_MIN_SCANS,
                max_windows: int = LOCAL_WINDOWS, max_gap: float = MAX_GAP,
                stamp_tol: float = STAMP_TOL, threads: int | None = None) -> np.ndarray:
    """A trajectory's local share (SPEC 7f): the split of section 7e within short stretches
    of the path, where it cannot have drifted much; what their halves cross is what the
    place (people, doors, glass) and the laser cross.

    Parameters
    ----------
    scans : Scans
        The laser scans, in time order.
    poses : Trajectory or array_like
        As :func:`scan_split`'s.
    window : float
        Metres of travel a window spans at most.
    max_scans, min_scans : int
        Scans a window scores at most (evenly thinned), and at least (else it is left out).
    max_windows : int
        Windows scored at most (evenly spread over the path).
    max_gap, stamp_tol : float
        Seconds, for a :class:`Trajectory`.
    threads : int, optional
        Worker threads per window (None: every core); the result does not depend on it.

    Returns
    -------
    numpy.ndarray
        Each window's crossing share (:attr:`ScanSplit.crossing_share`); the local share is
        their mean (``numpy.nanmean``; empty when no window has ``min_scans`` scans).

    Examples
    --------
    >>> a = np.array([0.0, np.pi])                   # a laser looking both ways
    >>> s = Scans(np.arange(40.0), a, np.full((40, 2), 1.03), 10.0)
    >>> poses = np.zeros((40, 3)); poses[:, 1] = 0.05
    >>> poses[20:, 0] = 1.5                           # a jump between the two windows
    >>> local_split(s, poses, window=0.1).tolist()    # each window is consistent
    [0.0, 0.0]
    >>> scan_split(s, poses).crossing_share           # the whole path is not
    0.5
    """
    n_threads = None if threads is None else check_threads(threads)
    return _local(scan_split, scans, poses, window, max_scans, min_scans, max_windows,
                  max_gap, stamp_tol, threads=n_threads)


def local_split_reference(scans: Scans, poses: Trajectory | Any, *,
                          window: float = LOCAL_WINDOW, max_scans: int = LOCAL_SCANS,
                          min_scans: int = LOCAL_MIN_SCANS,
                          max_windows: int = LOCAL_WINDOWS, max_gap: float = MAX_GAP,
                          stamp_tol: float = STAMP_TOL) -> np.ndarray:
    """:func:`local_split` with :func:`scan_split_reference`: the same windows and shares.

    Examples
    --------
    >>> a = np.array([0.0, np.pi])
    >>> s = Scans(np.arange(40.0), a, np.full((40, 2), 1.03), 10.0)
    >>> poses = np.zeros((40, 3)); poses[:, 1] = 0.05; poses[20:, 0] = 1.5
    >>> local_split_reference(s, poses, window=0.1).tolist()
    [0.0, 0.0]
    """
    return _local(scan_split_reference, scans, poses, window, max_scans, min_scans,
                  max_windows, max_gap, stamp_tol)
