"""A planned drive through a world: a collision-free path that visits its rooms and closes
loops, time-parametrised like a differential-drive robot.

The planner keeps a clearance from every wall (and from unknown cells) on a distance
transform, picks one waypoint per room (or spread over the free space of a map without
rooms), orders them into a closed tour (nearest neighbour then 2-opt on path lengths), and
joins them with shortest paths straightened by line-of-sight shortcuts and rounded corners.
The robot then follows the path at a constant speed, its heading turning at a bounded rate
(turning in place when the path turns sharply), optionally pausing at waypoints or being
kidnapped (carried to another place without its odometry knowing).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from slamq.errors import SlamqError
from slamq.models import OccupancyMap

__all__ = ["Drive", "clearance", "drive"]

#: The clearance bound's allowance: a point anywhere in a cell whose centre is ``d`` cells
#: from the nearest obstacle cell's centre is at least ``d - _SLACK`` cells from that cell.
_SLACK = math.sqrt(2.0) + 1e-6
#: Planning grid: this many map cells a side per planning cell.
_COARSE = 2


@dataclass(eq=False)
class Drive:
    """A time-parametrised drive.

    Attributes
    ----------
    stamps : numpy.ndarray
        ``(N,)`` float64 seconds from 0, one per ``1 / rate``.
    poses : numpy.ndarray
        ``(N, 3)`` float64 ``(x, y, yaw)`` in the world frame.
    meta : dict
        ``waypoints`` (``[x, y]`` in visiting order), ``length`` (metres driven),
        ``kidnaps`` (indices ``i`` where the robot was carried from pose ``i - 1`` to
        ``i``), ``pauses``, and the parameters.
    """

    stamps: np.ndarray
    poses: np.ndarray
    meta: dict[str, Any] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.stamps)


def clearance(world: OccupancyMap) -> np.ndarray:
    """A lower bound of the distance (metres) from any point of each cell to the nearest
    obstacle: occupied (including transparent walls) or unknown cells. ``(H, W)`` float32;
    0 on obstacles.

    Examples
    --------
    >>> from slamq.synth.worldgen import world
    >>> w = world(0, kind="hall", size=(10.0, 8.0))
    >>> c = clearance(w)
    >>> c.shape == w.shape, float(c.max()) > 1.0
    (True, True)
    """
    import cv2

    if world.resolution is None:
        raise SlamqError(f"{world.source}: a world needs a resolution")
    free = ((world.values >= 128) & ~world.unknown).astype(np.uint8)
    d = cv2.distanceTransform(free, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    return np.where(free > 0, np.maximum(d - _SLACK, 0.0) * world.resolution, 0.0).astype(
        np.float32)


class _Planner:
    def __init__(self, world: OccupancyMap, margin: float) -> None:
        self.world = world
        self.res = float(world.resolution)  # type: ignore[arg-type]
        self.h, self.w = world.shape
        self.ox, self.oy, yaw = world.origin
        if abs(yaw) > 1e-12:
            raise SlamqError(f"{world.source}: the drive needs a map with origin yaw 0")
        self.clear = clearance(world)
        self.ok = self.clear >= margin
        k = _COARSE
        hc, wc = self.h // k, self.w // k
        blocks = self.ok[:hc * k, :wc * k].reshape(hc, k, wc, k)
        self.coarse_ok = blocks.all(axis=(1, 3))
        self.coarse_clear = self.clear[:hc * k, :wc * k].reshape(hc, k, wc, k).min(axis=(1, 3))

    # frames: world (x, y) <-> fine cell (r, c) <-> coarse cell
    def cell(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        c = np.floor((np.asarray(x) - self.ox) / self.res).astype(np.int64)
        r = self.h - 1 - np.floor((np.asarray(y) - self.oy) / self.res).astype(np.int64)
        return r, c

    def coarse_xy(self, r: np.ndarray, c: np.ndarray) -> np.ndarray:
        k = _COARSE
        x = self.ox + (np.asarray(c) * k + k / 2) * self.res
        y = self.oy + (self.h - np.asarray(r) * k - k / 2) * self.res
        return np.column_stack([x, y])

    def free_at(self, pts: np.ndarray) -> np.ndarray:
        r, c = self.cell(pts[:, 0], pts[:, 1])
        inside = (r >= 0) & (r < self.h) & (c >= 0) & (c < self.w)
        out = np.zeros(len(pts), bool)
        out[inside] = self.ok[r[inside], c[inside]]
        return out

    def visible(self, a: np.ndarray, b: np.ndarray) -> bool:
        n = max(2, int(math.ceil(np.hypot(*(b - a)) / (self.res / 3))) + 1)
        t = np.linspace(0.0, 1.0, n)[:, None]
        return bool(self.free_at(a + t * (b - a)).all())

    def field(self, r: int, c: int, targets: list[tuple[int, int]]) -> np.ndarray:
        """Path lengths (coarse cells, octagonal metric) from coarse cell ``(r, c)`` over the
        drivable coarse cells, grown until every target is reached (or nothing more is);
        -1 where not reached. Every cell nearer than the farthest target is settled, so
        that a descent from a target stays on reached cells."""
        import cv2

        ok = self.coarse_ok.astype(np.uint8)
        dist = np.full(ok.shape, -1, np.int32)
        reached = np.zeros(ok.shape, np.uint8)
        reached[r, c] = 1
        dist[r, c] = 0
        cross = cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3))
        square = np.ones((3, 3), np.uint8)
        tr = np.array([t[0] for t in targets], np.int64)
        tc = np.array([t[1] for t in targets], np.int64)
        step = 0
        while True:
            step += 1
            grown = cv2.dilate(reached, square if step % 3 == 2 else cross) & ok
            new = grown > reached
            if not new.any():
                return dist
            dist[new] = step
            reached = grown
            if (dist[tr, tc] >= 0).all():
                return dist

    def descend(self, field: np.ndarray, r: int, c: int) -> list[tuple[int, int]]:
        """The coarse cells from ``(r, c)`` down ``field`` to its source."""
        path = [(r, c)]
        hc, wc = field.shape
        while field[r, c] > 0:
            best = None
            for dr in (-1, 0, 1):
                for dc in (-1, 0, 1):
                    rr, cc = r + dr, c + dc
                    if not (dr or dc) or not (0 <= rr < hc and 0 <= cc < wc):
                        continue
                    # (a diagonal step between the corners of two cells stays within
                    # them: their clearance bound holds on their closed squares)
                    if field[rr, cc] >= 0:
                        key = (field[rr, cc], -self.coarse_clear[rr, cc])
                        if best is None or key < best[0]:
                            best = (key, rr, cc)
            if best is None or best[0][0] >= field[r, c]:
                raise SlamqError("drive: internal error, a path lost its way")
            r, c = best[1], best[2]
            path.append((r, c))
        return path

    def straighten(self, pts: np.ndarray) -> np.ndarray:
        """Line-of-sight shortcuts, then rounded corners where they stay drivable."""
        keep = [0]
        i, n = 0, len(pts)
        while i < n - 1:
            # the farthest point seen from pts[i]: exponential, then binary search
            j, step = i + 1, 1
            while j + step <= n - 1 and self.visible(pts[i], pts[j + step]):
                j += step
                step *= 2
            lo, hi = j, min(j + step, n)
            while hi - lo > 1:
                mid = (lo + hi) // 2
                if self.visible(pts[i], pts[mid]):
                    lo = mid
                else:
                    hi = mid
            keep.append(lo)
            i = lo
        line = pts[keep]
        for _ in range(3):  # Chaikin corner cutting, kept when every piece is drivable
            if len(line) < 3:
                break
            q = 0.75 * line[:-1] + 0.25 * line[1:]
            r = 0.25 * line[:-1] + 0.75 * line[1:]
            cut = np.empty((2 * len(q), 2))
            cut[0::2], cut[1::2] = q, r
            cut = np.vstack([line[:1], cut[1:-1], line[-1:]])
            if not all(self.visible(a, b) for a, b in zip(cut[:-1], cut[1:])):
                break
            line = cut
        return line


def _waypoints(p: _Planner, world: OccupancyMap, rng: np.random.Generator,
               label: np.ndarray) -> list[tuple[int, int]]:
    """One coarse cell per room (the most open place in it, among the near-best chosen by
    the seed), or spread over the free space (farthest points) without rooms."""
    hc, wc = p.coarse_ok.shape
    cand = p.coarse_ok & (label > 0)
    centres = p.coarse_xy(*np.indices((hc, wc)).reshape(2, -1)).reshape(hc, wc, 2)
    pts: list[tuple[int, int]] = []
    for room in world.meta.get("rooms") or []:
        x0, y0, x1, y1 = room["box"]
        inside = (cand & (centres[..., 0] > x0) & (centres[..., 0] < x1)
                  & (centres[..., 1] > y0) & (centres[..., 1] < y1))
        if not inside.any():
            continue
        score = np.where(inside, p.coarse_clear, -1.0)
        good = np.argwhere(score >= 0.8 * score.max())
        r, c = good[rng.integers(len(good))]
        pts.append((int(r), int(c)))
    if len(pts) < 2:
        cells = np.argwhere(cand)
        area = len(cells) * (p.res * _COARSE) ** 2
        k = int(np.clip(area / 12.0, 4, 16))
        first = cells[rng.integers(len(cells))]
        chosen = [first]
        d = np.hypot(*(cells - first).T)
        # prefer open places: distance weighted by clearance
        weight = np.sqrt(p.coarse_clear[cells[:, 0], cells[:, 1]] + 0.1)
        for _ in range(k - 1):
            i = int(np.argmax(d * weight))
            chosen.append(cells[i])
            d = np.minimum(d, np.hypot(*(cells - cells[i]).T))
        pts = [(int(r), int(c)) for r, c in chosen]
    return pts


def _tour(dist: np.ndarray, start: int) -> list[int]:
    """A short closed tour from ``start`` over every index (nearest neighbour, then 2-opt)."""
    n = len(dist)
    order, left = [start], set(range(n)) - {start}
    while left:
        nxt = min(left, key=lambda j: (dist[order[-1], j], j))
        order.append(nxt)
        left.remove(nxt)
    order.append(start)
    improved = True
    while improved:
        improved = False
        for i in range(1, n - 1):
            for j in range(i + 1, n):
                a, b, c, d = order[i - 1], order[i], order[j], order[j + 1]
                if dist[a, c] + dist[b, d] < dist[a, b] + dist[c, d] - 1e-9:
                    order[i:j + 1] = order[i:j + 1][::-1]
                    improved = True
    return order


def drive(world: OccupancyMap, seed: int = 0, *, speed: float = 0.5, rate: float = 10.0,
          clearance_m: float = 0.35, turn_rate: float = math.radians(60.0),
          length: float | None = None, laps: int = 1, pauses: int = 0,
          pause_s: float = 3.0, kidnaps: int = 0) -> Drive:
    """A seeded collision-free drive through ``world`` that visits its rooms and returns
    to where it started (a closed loop).

    Parameters
    ----------
    world : OccupancyMap
        A world (:func:`slamq.synth.worldgen.world`, :func:`~slamq.synth.worldgen.load_world`);
        its origin's yaw must be 0. Rooms in ``meta["rooms"]`` are visited, else places
        spread over its free space.
    seed : int
        Which waypoints, start and tour; the same seed gives the same drive.
    speed : float, default 0.5
        Metres per second along the path.
    rate : float, default 10.0
        Poses per second.
    clearance_m : float, default 0.35
        The least distance from any wall or unknown cell, metres.
    turn_rate : float, default 60 degrees per second
        The most the heading turns per second, radians; the robot turns in place when the
        path turns by more than 45 degrees.
    length : float, optional
        Visit only the waypoints (in tour order) that keep the closed tour within this
        many metres of planned path (the drive still returns to its start; the smoothed
        path is a little shorter).
    laps : int, default 1
        Drive the tour this many times (later laps revisit every place).
    pauses : int, default 0
        Stand still for ``pause_s`` seconds at this many waypoints (seeded).
    kidnaps : int, default 0
        Carry the robot from this many waypoints to the next one without driving (its
        odometry sees no motion: ``meta["kidnaps"]``).

    Returns
    -------
    Drive

    Examples
    --------
    >>> from slamq.synth.worldgen import world
    >>> d = drive(world(0, kind="office", size=(12.0, 9.0)), seed=1)
    >>> len(d) > 100, d.meta["length"] > 10.0
    (True, True)
    >>> bool(abs(d.poses[0, :2] - d.poses[-1, :2]).max() < 1e-9)  # back where it started
    True
    """
    for name, v in (("speed", speed), ("rate", rate), ("turn_rate", turn_rate)):
        if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
            raise SlamqError(f"drive: {name} must be a positive number, got {v!r}")
    if not (math.isfinite(clearance_m) and clearance_m >= 0):
        raise SlamqError(f"drive: clearance_m must be >= 0, got {clearance_m!r}")
    if laps < 1 or pauses < 0 or kidnaps < 0:
        raise SlamqError("drive: laps must be >= 1, pauses and kidnaps >= 0")
    if world.resolution is None:
        raise SlamqError(f"{world.source}: a world needs a resolution")
    import cv2

    rng = np.random.default_rng(seed)
    p = _Planner(world, clearance_m + 0.02)
    n_lab, label = cv2.connectedComponents(p.coarse_ok.astype(np.uint8), connectivity=8)
    if n_lab < 2:
        raise SlamqError(f"{world.source}: no place keeps {clearance_m} m from every wall")
    sizes = np.bincount(label.ravel())
    sizes[0] = 0
    label = np.where(label == int(np.argmax(sizes)), 1, 0)
    pts = _waypoints(p, world, rng, label)
    if len(pts) < 2:
        raise SlamqError(f"{world.source}: too little room to drive")
    fields = [p.field(r, c, pts) for r, c in pts]
    step = p.res * _COARSE
    dist = np.array([[f[r, c] * step for (r, c) in pts] for f in fields], float)
    start = int(rng.integers(len(pts)))
    order = _tour(dist, start)
    if length is not None:
        kept, run = [start], 0.0
        for nxt in order[1:-1]:  # in tour order, skipping the places too far to fit
            if len(kept) >= 2 and run + dist[kept[-1], nxt] + dist[nxt, start] > length:
                continue
            run += dist[kept[-1], nxt]
            kept.append(nxt)
        order = kept + [start]
    order = order[:-1] * laps + [start]
    legs = []
    for a, b in zip(order[:-1], order[1:]):
        cells = p.descend(fields[b], *pts[a])
        xy = p.coarse_xy(*np.array(cells).T)
        legs.append(p.straighten(xy))
    inner = list(range(1, len(legs)))
    rng.shuffle(inner)
    pause_at = set(inner[:pauses])
    kidnap_at = set(inner[pauses:pauses + kidnaps])
    poses, kid, pause_idx = _follow(legs, speed, rate, turn_rate, pause_at, kidnap_at,
                                    pause_s)
    driven = sum(float(np.hypot(*np.diff(leg, axis=0).T).sum())
                 for i, leg in enumerate(legs) if i not in kidnap_at)
    meta = {"seed": int(seed), "speed": speed, "rate": rate, "clearance": clearance_m,
            "turn_rate": turn_rate, "laps": laps, "length": round(driven, 3),
            "waypoints": [[round(float(v), 3) for v in p.coarse_xy(*pts[i])[0]]
                          for i in order],
            "kidnaps": kid, "pauses": pause_idx}
    return Drive(np.arange(len(poses)) / rate, poses, meta)


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


def _follow(legs: list[np.ndarray], speed: float, rate: float, turn_rate: float,
            pause_at: set[int], kidnap_at: set[int], pause_s: float
            ) -> tuple[np.ndarray, list[int], list[int]]:
    """Poses every ``1 / rate`` seconds along the legs."""
    dt = 1.0 / rate
    ds, dyaw = speed * dt, turn_rate * dt
    out: list[tuple[float, float, float]] = []
    kidnaps: list[int] = []
    pauses: list[int] = []
    yaw = None
    for i, leg in enumerate(legs):
        seg = np.diff(leg, axis=0)
        seg_len = np.hypot(seg[:, 0], seg[:, 1])
        keep = seg_len > 1e-9
        leg = np.vstack([leg[:1], leg[1:][keep]])
        seg, seg_len = seg[keep], seg_len[keep]
        if len(seg) == 0:
            continue
        s_at = np.concatenate([[0.0], np.cumsum(seg_len)])
        total = s_at[-1]
        heading = np.arctan2(seg[:, 1], seg[:, 0])

        def at(s: float, leg=leg, seg=seg, seg_len=seg_len, s_at=s_at) -> tuple[float, float]:
            k = min(int(np.searchsorted(s_at, s, side="right")) - 1, len(seg) - 1)
            f = (s - s_at[k]) / seg_len[k]
            return (float(leg[k, 0] + f * seg[k, 0]), float(leg[k, 1] + f * seg[k, 1]))

        def want(s: float, heading=heading, s_at=s_at, total=total) -> float:
            k = min(int(np.searchsorted(s_at, min(s + 0.2, total), side="right")) - 1,
                    len(heading) - 1)
            return float(heading[k])

        if i in kidnap_at and out:
            kidnaps.append(len(out))
            x, y = float(leg[-1, 0]), float(leg[-1, 1])
            yaw = want(total)
            out.append((x, y, yaw))
            continue
        if yaw is None:
            yaw = want(0.0)
            out.append((float(leg[0, 0]), float(leg[0, 1]), yaw))
        if i in pause_at:
            pauses.append(len(out))
            out.extend([out[-1]] * int(round(pause_s * rate)))
        s = 0.0
        while s < total - 1e-9:
            err = _wrap(want(s) - yaw)
            if abs(err) > math.radians(45.0):  # turn in place
                yaw = _wrap(yaw + math.copysign(min(abs(err), dyaw), err))
                out.append((out[-1][0], out[-1][1], yaw))
                continue
            yaw = _wrap(yaw + max(-dyaw, min(dyaw, err)))
            s = min(s + ds, total)
            x, y = at(s)
            out.append((x, y, yaw))
    return np.array(out, float).reshape(-1, 3), kidnaps, pauses
