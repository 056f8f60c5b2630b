"""The simulator's sensors: exact laser ray casting on a world's grid, and odometry with
controllable noise.

- :func:`cast` (the Rust core, ``rust/src/raycast.rs``) and :func:`cast_numpy` (its plain
  numpy twin, the same walk): the exact distance from the laser to where each beam
  enters the first cell that stops it, ``inf`` beyond the maximum range.
- :func:`laser_scans`: a :class:`~slamq.synth.LaserSpec`'s scans along a path, with its
  seeded range noise and minimum range.
- :func:`odometry` and :data:`NOISE`: the odometry a wheel encoder would report along a
  path, with seeded translation, rotation, scale and heading-bias errors.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from slamq import native
from slamq.errors import SlamqError
from slamq.models import OccupancyMap
from slamq.synth.recording import LaserSpec

__all__ = ["NOISE", "OdometryNoise", "blocking", "cast", "cast_numpy", "laser_scans",
           "odometry"]


def blocking(world: OccupancyMap) -> np.ndarray:
    """The cells that stop a laser beam: ``(H, W)`` uint8, 1 where the world is occupied
    (value < 128, known) and not transparent (``world.meta["transparent"]``, a bool mask
    of glass-like walls: in the map, but the laser passes through).

    Examples
    --------
    >>> import numpy as np
    >>> from slamq import OccupancyMap
    >>> v = np.array([[0, 254, 0]], np.uint8)
    >>> m = OccupancyMap(v, np.zeros_like(v, bool), 0.05,
    ...                  meta={"transparent": np.array([[False, False, True]])})
    >>> blocking(m).tolist()
    [[1, 0, 0]]
    """
    blocked = (world.values < 128) & ~world.unknown
    glass = world.meta.get("transparent")
    if glass is not None:
        glass = np.asarray(glass, dtype=bool)
        if glass.shape != blocked.shape:
            raise SlamqError(f"{world.source}: transparent mask {glass.shape} differs from "
                             f"the map's shape {blocked.shape}")
        blocked &= ~glass
    return np.ascontiguousarray(blocked, dtype=np.uint8)


def _poses(poses: Any) -> np.ndarray:
    p = np.ascontiguousarray(poses, dtype=np.float64)
    if p.ndim == 1 and p.shape == (3,):
        p = p[None, :]
    if p.ndim != 2 or p.shape[1] != 3:
        raise SlamqError(f"poses must be an (n, 3) array of (x, y, yaw), got shape {p.shape}")
    if not np.isfinite(p).all():
        raise SlamqError("poses must be finite")
    return p


def _angles(angles: Any) -> np.ndarray:
    a = np.ascontiguousarray(angles, dtype=np.float64)
    if a.ndim != 1:
        raise SlamqError(f"angles must be a 1-D array, got shape {a.shape}")
    if not np.isfinite(a).all():
        raise SlamqError("angles must be finite")
    return a


def _grid(world: OccupancyMap) -> tuple[np.ndarray, float, tuple[float, float, float]]:
    if world.resolution is None:
        raise SlamqError(f"{world.source}: a world needs a resolution (metres per cell)")
    return blocking(world), float(world.resolution), tuple(world.origin)  # type: ignore


def _max_range(max_range: float) -> float:
    r = float(max_range)
    if not r > 0:
        raise SlamqError(f"max_range must be positive, got {max_range}")
    return r


def cast(world: OccupancyMap, poses: Any, angles: Any, max_range: float,
         threads: int | None = None) -> np.ndarray:
    """Exact laser ranges in ``world`` (Rust core, GIL released, scans in parallel).

    Parameters
    ----------
    world : OccupancyMap
        Cells with value < 128 stop a beam, except those in ``world.meta["transparent"]``.
    poses : array_like
        ``(n, 3)`` laser poses ``(x, y, yaw)`` in the world frame (metres, radians).
    angles : array_like
        ``(b,)`` beam angles relative to the yaw, radians.
    max_range : float
        Metres (may be ``inf``).
    threads : int, optional
        Worker threads (None: every core); the result is the same for any number.

    Returns
    -------
    numpy.ndarray
        ``(n, b)`` float64 metres to where each beam enters its first blocking cell (0 when
        the laser is inside one); ``inf`` = no such cell within ``max_range`` or the grid.

    Examples
    --------
    >>> import numpy as np
    >>> from slamq import OccupancyMap
    >>> v = np.full((10, 10), 254, np.uint8); v[:, 7] = 0
    >>> m = OccupancyMap(v, np.zeros_like(v, bool), 0.1)
    >>> cast(m, [[0.25, 0.55, 0.0]], [0.0, np.pi], 10.0).tolist()
    [[0.45, inf]]
    """
    if threads is not None and threads < 1:
        raise SlamqError(f"threads must be >= 1 or None, got {threads}")
    blocked, res, origin = _grid(world)
    try:
        return native.raycast(blocked, res, origin, _poses(poses), _angles(angles),
                              _max_range(max_range), threads or 0)
    except ValueError as exc:  # the core's own checks (sizes)
        raise SlamqError(f"{world.source}: {exc}") from None


def cast_numpy(world: OccupancyMap, poses: Any, angles: Any, max_range: float) -> np.ndarray:
    """The numpy twin of :func:`cast`: the same Amanatides-Woo walk in numpy, all beams of a
    scan at once (slow; for tests and benchmarks).

    Examples
    --------
    >>> import numpy as np
    >>> from slamq import OccupancyMap
    >>> v = np.full((10, 10), 254, np.uint8); v[:, 7] = 0
    >>> m = OccupancyMap(v, np.zeros_like(v, bool), 0.1)
    >>> cast_numpy(m, [[0.25, 0.55, 0.0]], [0.0, np.pi], 10.0).tolist()
    [[0.45, inf]]
    """
    blocked, res, origin = _grid(world)
    poses, angles, max_range = _poses(poses), _angles(angles), _max_range(max_range)
    h, w = blocked.shape
    pw = w + 2
    cells = np.full((h + 2, pw), 2, np.uint8)
    cells[1:-1, 1:-1] = blocked
    cells = cells.ravel()
    c, s = math.cos(origin[2]), math.sin(origin[2])
    out = np.empty((len(poses), len(angles)))
    t_range = max_range / res
    for k, (x, y, yaw) in enumerate(poses):
        wx, wy = x - origin[0], y - origin[1]
        ox = (c * wx + s * wy) / res
        oy = (c * wy - s * wx) / res
        a = (yaw + angles) - origin[2]
        out[k] = _walk(cells, h, w, ox, oy, np.cos(a), np.sin(a), t_range) * res
    return out


def _walk(cells: np.ndarray, h: int, w: int, ox: float, oy: float, dx: np.ndarray,
          dy: np.ndarray, t_range: float) -> np.ndarray:
    """Beam parameters (cells) at which each beam from ``(ox, oy)`` (grid units) enters
    its first blocking cell, ``inf`` for none: ``rust/src/raycast.rs``'s ``cast``."""
    n = len(dx)
    t0, alive, idx, tx, tdx, sx, ty, tdy, sy = walk_start(h, w, ox, oy, dx, dy,
                                                          np.full(n, t_range),
                                                          np.ones(n, bool))
    result = np.full(n, np.inf)
    t = t0.copy()
    live = np.flatnonzero(alive)
    idx = np.where(alive, idx, 0)
    while live.size:
        v = cells[idx[live]]
        stop = v != 0
        if stop.any():
            done = live[stop]
            hit = (v[stop] == 1) & (t[done] <= t_range)
            result[done[hit]] = t[done[hit]]
            live = live[~stop]
        step_x = tx[live] < ty[live]
        tl = np.where(step_x, tx[live], ty[live])
        t[live] = tl
        far = tl > t_range
        live = live[~far]
        step_x = step_x[~far]
        tx[live] += np.where(step_x, tdx[live], 0.0)
        ty[live] += np.where(step_x, 0.0, tdy[live])
        idx[live] += np.where(step_x, sx[live], sy[live])
    return result


def laser_scans(world: OccupancyMap, gt: Any, laser: LaserSpec | None = None, *,
                seed: int | np.random.Generator | None = 0,
                threads: int | None = None) -> np.ndarray:
    """The scans a :class:`LaserSpec` on a robot at the ground-truth poses ``gt`` reads in
    ``world``: exact ranges (:func:`cast`) plus Gaussian noise of ``laser.range_noise``
    (seeded), ``inf`` where there is no return (beyond ``max_range``, or nearer than
    ``min_range``).

    Returns
    -------
    numpy.ndarray
        ``(n, laser.beams)`` float32 metres.

    Examples
    --------
    >>> import numpy as np
    >>> from slamq import OccupancyMap
    >>> v = np.full((10, 10), 254, np.uint8); v[:, 7] = 0
    >>> m = OccupancyMap(v, np.zeros_like(v, bool), 0.1)
    >>> laser_scans(m, [[0.25, 0.55, 0.0]], LaserSpec(beams=1, fov=0.0, range_noise=0.0))
    array([[0.45]], dtype=float32)
    """
    laser = LaserSpec() if laser is None else laser
    gt = _poses(gt)
    ox, oy, oyaw = (float(v) for v in laser.offset)
    c, s = np.cos(gt[:, 2]), np.sin(gt[:, 2])
    poses = np.column_stack([gt[:, 0] + c * ox - s * oy, gt[:, 1] + s * ox + c * oy,
                             gt[:, 2] + oyaw])
    ranges = cast(world, poses, laser.angles(), laser.max_range, threads=threads)
    if laser.range_noise > 0:
        rng = np.random.default_rng(seed)
        ranges += rng.standard_normal(ranges.shape) * laser.range_noise
    ranges[(ranges < laser.min_range) | (ranges > laser.max_range)] = np.inf
    return ranges.astype(np.float32)


@dataclass(frozen=True)
class OdometryNoise:
    """How wrong the odometry is, per step (every error scales with the step's motion, so
    that it does not depend on the rate).

    Attributes
    ----------
    translation : float
        Standard deviation of the translation error along and across the step, metres per
        sqrt(metre travelled).
    rotation : float
        Standard deviation of the heading error, radians per sqrt(metre travelled).
    turn : float
        Standard deviation of the heading error, radians per sqrt(radian turned).
    scale : float
        Systematic scale error of the travelled distance (0.02 = odometry reads 2 % long).
    heading_bias : float
        Systematic heading drift, radians per metre travelled (counter-clockwise positive).

    Examples
    --------
    >>> NOISE["low"].translation
    0.01
    """

    translation: float = 0.0
    rotation: float = 0.0
    turn: float = 0.0
    scale: float = 0.0
    heading_bias: float = 0.0

    def to_dict(self) -> dict[str, float]:
        return asdict(self)


#: Named odometry noise levels (``simulate(noise=...)``, ``slamq synth sequence --noise``).
NOISE: dict[str, OdometryNoise] = {
    "none": OdometryNoise(),
    "low": OdometryNoise(translation=0.01, rotation=math.radians(0.5),
                         turn=math.radians(0.5)),
    "high": OdometryNoise(translation=0.04, rotation=math.radians(2.0), turn=math.radians(2.0),
                          scale=0.02, heading_bias=math.radians(0.5)),
}


def odometry_noise(noise: str | OdometryNoise | dict[str, float]) -> OdometryNoise:
    """A noise level from its name in :data:`NOISE`, a dict of its fields, or itself."""
    if isinstance(noise, OdometryNoise):
        return noise
    if isinstance(noise, str):
        if noise not in NOISE:
            raise SlamqError(f"unknown odometry noise {noise!r}: one of {', '.join(NOISE)}")
        return NOISE[noise]
    if isinstance(noise, dict):
        try:
            return OdometryNoise(**noise)
        except TypeError as exc:
            raise SlamqError(f"odometry noise: {exc}") from None
    raise SlamqError(f"odometry noise must be a name, a dict or an OdometryNoise, got "
                     f"{type(noise).__name__}")


def _wrap(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2 * np.pi) - np.pi


def increments(poses: np.ndarray) -> np.ndarray:
    """Each step's motion ``(dx, dy, dyaw)`` in the frame of the pose it starts from,
    ``(n - 1, 3)``."""
    d = np.diff(poses, axis=0)
    c, s = np.cos(poses[:-1, 2]), np.sin(poses[:-1, 2])
    return np.column_stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1],
                            _wrap(d[:, 2])])


def compose(start: np.ndarray, steps: np.ndarray) -> np.ndarray:
    """The poses reached from ``start`` by the robot-frame ``steps``, ``(n + 1, 3)``, the
    heading unwrapped (continuous)."""
    yaw = start[2] + np.concatenate([[0.0], np.cumsum(steps[:, 2])])
    c, s = np.cos(yaw[:-1]), np.sin(yaw[:-1])
    x = start[0] + np.concatenate([[0.0], np.cumsum(c * steps[:, 0] - s * steps[:, 1])])
    y = start[1] + np.concatenate([[0.0], np.cumsum(s * steps[:, 0] + c * steps[:, 1])])
    return np.column_stack([x, y, yaw])


def odometry(gt: Any, noise: str | OdometryNoise = "low", *,
             seed: int | np.random.Generator | None = 0,
             carried: Any = ()) -> np.ndarray:
    """The odometry along the ground-truth path ``gt``: its per-step motions in the robot
    frame, each with seeded errors, composed from the first pose (``odom`` = ``map`` at
    time 0).

    Per step of length ``d`` metres and turn ``dθ`` radians: the step's length is scaled by
    ``1 + noise.scale``; the translation gets Gaussian errors of standard deviation
    ``noise.translation * sqrt(d)`` along and across it; the heading gets ``noise.rotation
    * sqrt(d) + noise.turn * sqrt(|dθ|)`` of Gaussian error and ``noise.heading_bias * d``
    of drift. With no noise the odometry is the ground truth (to rounding). The steps into
    the indices ``carried`` (kidnaps: the robot was carried) are not seen: no motion.

    Returns
    -------
    numpy.ndarray
        ``(n, 3)`` float64 ``(x, y, yaw)``, the yaw in ``[-pi, pi)``.

    Examples
    --------
    >>> import numpy as np
    >>> gt = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, np.pi / 2]])
    >>> np.abs(odometry(gt, "none") - gt).max() < 1e-12
    np.True_
    >>> odometry(gt, "high", seed=1)[-1].round(2).tolist() != gt[-1].tolist()
    True
    """
    gt = _poses(gt)
    nz = odometry_noise(noise)
    if len(gt) < 2:
        return gt.copy()
    steps = increments(gt)
    carried = np.asarray(carried, dtype=np.int64)
    if carried.size:
        if ((carried < 1) | (carried >= len(gt))).any():
            raise SlamqError(f"carried indices must be within 1..{len(gt) - 1}")
        steps[carried - 1] = 0.0
    length = np.hypot(steps[:, 0], steps[:, 1])
    if nz != NOISE["none"]:
        rng = np.random.default_rng(seed)
        e = rng.standard_normal((len(steps), 3))
        steps[:, :2] *= 1.0 + nz.scale
        root = np.sqrt(length)
        steps[:, 0] += e[:, 0] * nz.translation * root
        steps[:, 1] += e[:, 1] * nz.translation * root
        steps[:, 2] += (e[:, 2] * (nz.rotation * root + nz.turn * np.sqrt(np.abs(steps[:, 2])))
                        + nz.heading_bias * length)
    out = compose(gt[0], steps)
    if nz == NOISE["none"] and not carried.size:
        out[:, 2] = gt[:, 2]  # exact, not the sum of wrapped differences
    out[:, 2] = _wrap(out[:, 2])
    return out


def walk_start(h: int, w: int, ox: float, oy: float, dx: np.ndarray, dy: np.ndarray,
               t_end: np.ndarray, alive: np.ndarray) -> tuple[np.ndarray, ...]:
    """Where each beam from ``(ox, oy)`` (grid units, direction ``(dx, dy)``) enters an
    ``h x w`` grid padded by one cell, and the Amanatides-Woo steps from there: ``(t0, alive,
    idx, tx, tdx, sx, ty, tdy, sy)``. ``t_end`` caps each beam, ``alive`` (changed in place)
    says which beams are cast; a beam that misses the grid before ``t_end`` is not alive.
    The first steps of the numpy twins of ``rust/src/raycast.rs`` and ``rust/src/scans.rs``
    (:func:`_walk` here, ``slamq.metrics.scans``), which must take them identically.

    Examples
    --------
    >>> t0, alive, idx, *_ = walk_start(2, 2, -1.0, 0.5, np.array([1.0]), np.array([0.0]),
    ...                                 np.array([5.0]), np.ones(1, bool))
    >>> float(t0[0]), bool(alive[0]), int(idx[0])
    (1.0, True, 9)
    """
    t0 = np.zeros(len(dx))
    t1 = np.array(t_end, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        for o, d, size in ((ox, dx, float(w)), (oy, dy, float(h))):
            flat = d == 0.0
            if not 0.0 <= o < size:
                alive &= ~flat
            ta, tb = (0.0 - o) / d, (size - o) / d
            t0 = np.where(flat, t0, np.maximum(t0, np.minimum(ta, tb)))
            t1 = np.where(flat, t1, np.minimum(t1, np.maximum(ta, tb)))
        alive &= t0 <= t1
        ix = np.clip(np.floor(ox + t0 * dx), 0.0, w - 1.0)
        iy = np.clip(np.floor(oy + t0 * dy), 0.0, h - 1.0)
        pw = w + 2
        idx = (h - iy.astype(np.int64)) * pw + ix.astype(np.int64) + 1
        pos_x, neg_x, pos_y, neg_y = dx > 0, dx < 0, dy > 0, dy < 0
        tx = np.where(pos_x, (ix + 1.0 - ox) / dx,
                      np.where(neg_x, (ix - ox) / dx, np.inf))
        tdx = np.where(pos_x, 1.0 / dx, np.where(neg_x, -1.0 / dx, 0.0))
        sx = np.where(pos_x, 1, np.where(neg_x, -1, 0))
        ty = np.where(pos_y, (iy + 1.0 - oy) / dy,
                      np.where(neg_y, (iy - oy) / dy, np.inf))
        tdy = np.where(pos_y, 1.0 / dy, np.where(neg_y, -1.0 / dy, 0.0))
        sy = np.where(pos_y, -pw, np.where(neg_y, pw, 0))
    return t0, alive, idx, tx, tdx, sx, ty, tdy, sy
