"""A tiny test world for the writers' tests and bench (the real simulator lives elsewhere):
walls as line segments, an exact ray cast against them in numpy, a drive along a closed
loop of waypoints, and odometry with optional drift. Not part of the package."""

from __future__ import annotations

import math

import cv2
import numpy as np

from slamq.models import OccupancyMap
from slamq.synth import LaserSpec, Recording

# An 16 x 10 m floor: outer walls, two rooms off a corridor loop, a pillar, a box.
WALLS = np.array([
    # outer box
    [0, 0, 16, 0], [16, 0, 16, 10], [16, 10, 0, 10], [0, 10, 0, 0],
    # inner block the corridor loops around (with a notch so the loop is not symmetric)
    [3, 3, 12, 3], [12, 3, 12, 5], [12, 5, 10, 5], [10, 5, 10, 7], [10, 7, 3, 7],
    [3, 7, 3, 3],
    # a room in the inner block's top-left, open to the corridor by a door gap
    [5, 7, 5, 5], [5, 5, 7, 5],
    # a pillar and a box in the corridor's corners
    [14, 1, 14.6, 1], [14.6, 1, 14.6, 1.6], [14.6, 1.6, 14, 1.6], [14, 1.6, 14, 1],
    [1, 8.3, 2, 8.3], [2, 8.3, 2, 9.0], [2, 9.0, 1, 9.0], [1, 9.0, 1, 8.3],
    # a short wall stub on the right
    [16, 6, 14.8, 6],
], dtype=np.float64)

LOOP = np.array([[1.5, 1.5], [13.5, 1.5], [14.5, 3.0], [14.5, 8.5], [11.0, 8.5],
                 [3.0, 8.5], [1.5, 7.0], [1.5, 1.5]])


def world_map(resolution: float = 0.05) -> OccupancyMap:
    w, h = int(round(16.4 / resolution)), int(round(10.4 / resolution))
    img = np.full((h, w), 254, np.uint8)
    ox = oy = -0.2
    for x0, y0, x1, y1 in WALLS:
        p0 = (int(round((x0 - ox) / resolution)), h - 1 - int(round((y0 - oy) / resolution)))
        p1 = (int(round((x1 - ox) / resolution)), h - 1 - int(round((y1 - oy) / resolution)))
        cv2.line(img, p0, p1, 0, 1)
    return OccupancyMap(img, np.zeros_like(img, bool), resolution, (ox, oy, 0.0),
                        source="<test world>")


def cast(poses: np.ndarray, laser: LaserSpec) -> np.ndarray:
    """Exact ranges (N, beams) float32 from laser poses (N, 3) against WALLS; inf = none."""
    ang = laser.angles()
    out = np.empty((len(poses), laser.beams), np.float32)
    a = WALLS[:, :2]
    e = WALLS[:, 2:] - a
    for lo in range(0, len(poses), 64):
        p = poses[lo:lo + 64]
        th = p[:, 2:3] + ang[None, :]                     # (n, B)
        dx, dy = np.cos(th)[..., None], np.sin(th)[..., None]  # (n, B, 1)
        ax = a[None, None, :, 0] - p[:, None, None, 0]
        ay = a[None, None, :, 1] - p[:, None, None, 1]
        den = dx * e[:, 1] - dy * e[:, 0]                 # cross(d, e)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (ax * e[:, 1] - ay * e[:, 0]) / den       # along the ray
            u = (ax * dy - ay * dx) / den                 # along the wall
        t = np.where((den != 0) & (u >= 0) & (u <= 1) & (t > 0), t, np.inf)
        out[lo:lo + 64] = t.min(axis=2)
    r = out
    r[(r > laser.max_range) | (r < laser.min_range)] = np.inf
    return r


def drive(n: int, step: float = 0.047, turn: float = math.radians(6)) -> np.ndarray:
    """(n, 3) poses along LOOP (repeated), ``step`` m per pose, turning on the spot by at
    most ``turn`` rad per pose at the corners."""
    out: list[tuple[float, float, float]] = []
    yaw = math.atan2(*(LOOP[1] - LOOP[0])[::-1])
    k = 0
    while len(out) < n:
        a, b = LOOP[k % (len(LOOP) - 1)], LOOP[k % (len(LOOP) - 1) + 1]
        target = math.atan2(b[1] - a[1], b[0] - a[0])
        dturn = math.atan2(math.sin(target - yaw), math.cos(target - yaw))
        m = int(math.ceil(abs(dturn) / turn))
        out += [(a[0], a[1], yaw + dturn * j / m) for j in range(1, m + 1)]
        yaw = target
        d = float(np.hypot(*(b - a)))
        m = max(1, int(round(d / step)))
        out += [(a[0] + (b[0] - a[0]) * j / m, a[1] + (b[1] - a[1]) * j / m, yaw)
                for j in range(m)]
        k += 1
    g = np.array(out[:n])
    g[:, 2] = np.angle(np.exp(1j * g[:, 2]))
    return g


def compose(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    c, s = np.cos(p[..., 2]), np.sin(p[..., 2])
    return np.stack([p[..., 0] + c * q[..., 0] - s * q[..., 1],
                     p[..., 1] + s * q[..., 0] + c * q[..., 1],
                     np.angle(np.exp(1j * (p[..., 2] + q[..., 2])))], axis=-1)


def make_sequence(n: int = 200, beams: int = 181, *, odom_noise: float = 0.0, seed: int = 0,
                  range_noise: float = 0.01, offset: tuple[float, float, float] = (0.1, 0.0, 0.0),
                  rate: float = 10.0, name: str = "room") -> Recording:
    """A drive of ``n`` scans; ``odom_noise`` scales the odometry's relative errors
    (0.05 = 5% of each step's translation and rotation, plus a small yaw bias)."""
    from slamq.synth.writers.rawlog import odometry_increments

    rng = np.random.default_rng(seed)
    laser = LaserSpec(beams=beams, fov=math.radians(270), max_range=20.0, min_range=0.05,
                      range_noise=range_noise, offset=offset)
    gt = drive(n)
    inc = odometry_increments(gt)
    if odom_noise:
        dist = np.hypot(inc[:, 0], inc[:, 1])
        inc = inc.copy()
        inc[:, 0] *= 1 + odom_noise * rng.standard_normal(n)
        inc[:, 1] += odom_noise * dist * rng.standard_normal(n)
        inc[:, 2] += (odom_noise * np.abs(inc[:, 2]) * rng.standard_normal(n)
                      + odom_noise * 0.2 * dist)  # yaw drift that grows with distance
    odom = np.empty_like(gt)
    odom[0] = gt[0]
    for i in range(1, n):
        odom[i] = compose(odom[i - 1], inc[i])
    lp = compose(gt, np.broadcast_to(np.asarray(offset, np.float64), gt.shape))
    ranges = cast(lp, laser)
    if range_noise:
        ranges += (range_noise * rng.standard_normal(ranges.shape)).astype(np.float32)
    stamps = np.arange(n) / rate
    return Recording(stamps, gt, odom, ranges, laser, world_map(), name=name,
                    meta={"world": "test room", "odom_noise": odom_noise, "seed": seed})
