"""``slamq.synth.damage``: synthetic map series with a known severity of damage.

Real maps come without a measured amount of damage; here the damage is made, so its
severity is known. From a floor plan (:func:`floor_plan`, procedural rooms, corridor, doors
and furniture; or any :class:`~slamq.OccupancyMap`), :func:`degrade` draws the map a SLAM
run with one kind of failure would have built:

- ``drift``: growing pose drift. The robot sweeps the plan along x; every cell is placed by
  the pose that saw it, whose heading error grows linearly with the distance travelled
  (severity: degrees per 10 m); the position error is the integral of that heading error,
  so the map bends progressively, as an odometry-only map does.
- ``doubling``: a failed loop closure. The half of the map revisited last (larger x) is
  drawn a second time, shifted by the severity (metres) in a seeded direction, over the
  first copy.
- ``rotation``: the whole map rotated by the severity (degrees) about its centre. A rotated
  map is as good as the original: the ideal metric does not move.
- ``specks``: the severity's share of the free cells turned occupied, at seeded places
  (scan noise, moving people).
- ``superposed``: a failed loop closure with a heading error. The half of the map revisited
  last (larger x) is drawn a second time, rotated by the severity (degrees, seeded sign)
  about its centre, over the first copy.
- ``kinks``: heading jumps of scan matching. The map is cut across x into three parts;
  each part after the first is turned by the severity (degrees, seeded sign) about the
  middle of its cut, on top of the turns before it: a corridor that bends where it should
  run straight, the parts overlapping only at the cuts.
- ``smear``: pose uncertainty while mapping. The walls of the half of the map seen last are
  drawn at headings spread evenly over the severity (degrees) about a pivot at that half's
  centre: walls fan out into wedges that grow with the distance from the pivot.

Each map is drawn by forward-mapping 3 x 3 sub-samples of every cell (a cell takes the
class of most of the sub-samples landing in it, so walls keep their thickness), so
severity 0 reproduces the plan cell for cell. The study of how each metric follows the
severity is studies/damage_study.py (outside the package).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from slamq.errors import ParamError
from slamq.models import OccupancyMap

__all__ = ["DEGRADATIONS", "SEVERITIES", "degrade", "floor_plan", "series"]

#: The kinds of damage and the unit of their severity.
DEGRADATIONS = {"drift": "deg per 10 m", "doubling": "m", "rotation": "deg",
                "specks": "share of free cells", "superposed": "deg", "smear": "deg",
                "kinks": "deg", "gap": "m"}
#: The default severities of each series (0 = the plan itself).
SEVERITIES: dict[str, tuple[float, ...]] = {
    "drift": (0.0, 0.5, 1.0, 2.0, 4.0, 8.0),
    "doubling": (0.0, 0.1, 0.2, 0.4, 0.8, 1.6),
    "rotation": (0.0, 1.0, 2.0, 5.0, 10.0, 20.0),
    "specks": (0.0, 0.001, 0.002, 0.005, 0.01, 0.02),
    "superposed": (0.0, 2.0, 5.0, 10.0, 20.0, 45.0),
    "smear": (0.0, 2.0, 5.0, 10.0, 20.0, 30.0),
    "kinks": (0.0, 2.0, 5.0, 10.0, 20.0, 30.0),
    "gap": (0.0, 0.5, 1.0, 2.0, 4.0, 8.0),
}
_SUB = 3  # sub-samples per cell side when drawing


def floor_plan(seed: int = 0, *, rooms: tuple[int, int] = (4, 3), room: float = 4.0,
               resolution: float = 0.05, wall: float = 0.1, door: float = 1.0,
               margin: float = 1.0) -> OccupancyMap:
    """A procedural floor plan: a grid of rooms with doors along a corridor, and furniture.

    The building is ``rooms[0] x rooms[1]`` rooms of about ``room`` metres (walls jittered
    by the seed) with a 1.6 m corridor across it above the first row; every room has a door
    (gap of ``door`` metres) to the corridor or to the room beside it, half of the walls
    between rooms have one too, and half of the rooms a piece of furniture. Inside the
    outer walls is free, outside unknown.

    Parameters
    ----------
    seed : int, default 0
        The plan is a function of the seed and the sizes.
    rooms : tuple of int, default (4, 3)
        Rooms along x and along y (at least 1 x 2).
    room, resolution, wall, door, margin : float
        Room size, metres per cell, wall thickness, door width, unknown border (metres).

    Returns
    -------
    OccupancyMap
        0 = wall, 254 = free, unknown outside; ``source`` names the seed.

    Examples
    --------
    >>> from slamq.synth import floor_plan
    >>> p = floor_plan(1)
    >>> p.shape, p.resolution
    ((312, 360), 0.05)
    >>> bool((p.values[~p.unknown] == 0).any()), p.known_count < p.values.size
    (True, True)
    >>> bool((floor_plan(1).values == p.values).all())
    True
    """
    nx, ny = rooms
    if nx < 1 or ny < 2:
        raise ParamError(f"rooms must be at least (1, 2), got {rooms!r}")
    rng = np.random.default_rng(seed)
    c = 1.0 / resolution
    corridor = 1.6
    width, height = nx * room, ny * room + corridor
    pad = int(round(margin * c))
    w_cells, h_cells = int(round(width * c)) + 2 * pad, int(round(height * c)) + 2 * pad
    occ = np.zeros((h_cells, w_cells), bool)
    t = max(1, int(round(wall * c)))
    d = int(round(door * c))

    def cell(x: float, y: float) -> tuple[int, int]:  # plan metres -> (row, col)
        return h_cells - 1 - (pad + int(round(y * c))), pad + int(round(x * c))

    def hwall(y: float, x0: float, x1: float) -> None:
        r, c0 = cell(x0, y)
        _, c1 = cell(x1, y)
        occ[r - t + 1:r + 1, c0:c1 + t] = True

    def vwall(x: float, y0: float, y1: float) -> None:
        r0, col = cell(x, y1)
        r1, _ = cell(x, y0)
        occ[r0 - t + 1:r1 + 1, col:col + t] = True

    def hgap(y: float, x0: float, x1: float) -> None:  # a door in a horizontal wall
        x = rng.uniform(x0 + 0.3, x1 - 0.3 - door)
        r, c0 = cell(x, y)
        occ[r - t + 1:r + 1, c0:c0 + d] = False

    def vgap(x: float, y0: float, y1: float) -> None:
        y = rng.uniform(y0 + 0.3, y1 - 0.3 - door)
        r0, col = cell(x, y + door)
        occ[r0:r0 + d, col:col + t] = False

    # outer walls
    hwall(0, 0, width)
    hwall(height, 0, width)
    vwall(0, 0, height)
    vwall(width, 0, height)
    # row bottoms: row 0 at y 0, the corridor above it, rows 1.. above the corridor
    bottoms = [0.0] + [room + corridor + (k - 1) * room for k in range(1, ny)]
    hwall(room, 0, width)
    hwall(room + corridor, 0, width)
    for k in range(2, ny):
        hwall(bottoms[k], 0, width)
    for k, y0 in enumerate(bottoms):
        y1 = y0 + room
        xs = [0.0] + [i * room + rng.uniform(-0.15, 0.15) * room for i in range(1, nx)] + [
            width]
        for i in range(1, nx):
            vwall(xs[i], y0, y1)
            if rng.random() < 0.5:
                vgap(xs[i], y0, y1)
        for i in range(nx):
            x0, x1 = xs[i], xs[i + 1]
            if k == 0:
                hgap(room, x0, x1)  # door up into the corridor
            elif k == 1:
                hgap(room + corridor, x0, x1)  # door down into the corridor
            else:
                hgap(y0, x0, x1)  # door down into the room below
            if rng.random() < 0.5:  # furniture: a block away from the walls
                fw, fh = rng.uniform(0.4, 1.2, 2)
                fx = rng.uniform(x0 + 0.6, x1 - 0.6 - fw)
                fy = rng.uniform(y0 + 0.6, y1 - 0.6 - fh)
                r0, c0 = cell(fx, fy + fh)
                r1, c1 = cell(fx + fw, fy)
                occ[r0:r1 + 1, c0:c1 + 1] = True
    r0, c0 = cell(0, height)
    r1, c1 = cell(width, 0)
    inside = np.zeros_like(occ)
    inside[r0 - t + 1:r1 + 1, c0:c1 + t] = True
    values = np.where(occ, 0, 254).astype(np.uint8)
    values[~inside] = 205
    return OccupancyMap(values, ~inside, resolution, (-pad * resolution, -pad * resolution,
                                                      0.0), source=f"<floor plan {seed}>")


Warp = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]


def _samples(mask: np.ndarray, res: float) -> tuple[np.ndarray, np.ndarray]:
    """Sub-sample positions (metres from the lower-left corner) of the cells of ``mask``."""
    h = mask.shape[0]
    r, c = np.nonzero(mask)
    off = (np.arange(_SUB) + 0.5) / _SUB
    cc = (c[:, None, None] + off[None, :, None]) + 0 * off[None, None, :]
    rr = (r[:, None, None] + 0 * off[None, :, None]) + off[None, None, :]
    return (cc * res).ravel(), ((h - rr) * res).ravel()


def _draw(plan: OccupancyMap, layers: list[tuple[np.ndarray, ...]], source: str
          ) -> OccupancyMap:
    """Draw ``(occupied, free, unknown, warp)`` layers of ``plan`` on a grid holding them.

    Within a layer a cell takes the class of the majority of the sub-samples landing in it
    (occupied needs more than half; so a moved wall keeps its thickness); the layers are
    superposed (occupied wins over free, known over unknown).
    """
    res = plan.resolution or 1.0
    h, w = plan.shape
    pts = []
    for *masks, warp in layers:
        drawn = []
        for mask in masks:
            u, v = warp(*_samples(mask, res))
            drawn.append((np.floor(u / res).astype(np.int64),
                          np.floor(h - v / res).astype(np.int64)))
        pts.append(drawn)
    cols = np.concatenate([c for d in pts for c, _ in d] + [np.array([0, w - 1])])
    rows = np.concatenate([r for d in pts for _, r in d] + [np.array([0, h - 1])])
    left, top = -min(0, int(cols.min())), -min(0, int(rows.min()))
    right, bottom = max(0, int(cols.max()) - (w - 1)), max(0, int(rows.max()) - (h - 1))
    shape = (h + top + bottom, w + left + right)
    occ_out = np.zeros(shape, bool)
    known = np.zeros(shape, bool)
    for drawn in pts:
        n_occ, n_free, n_unk = (np.zeros(shape, np.int64) for _ in range(3))
        for count, (c, r) in zip((n_occ, n_free, n_unk), drawn):
            np.add.at(count, (r + top, c + left), 1)
        occupied = n_occ > n_free + n_unk
        occ_out |= occupied
        known |= occupied | (n_occ + n_free > n_unk)
    values = np.where(occ_out, 0, np.where(known, 254, 205)).astype(np.uint8)
    x, y, yaw = plan.origin
    return OccupancyMap(values, ~known, plan.resolution,
                        (x - left * res, y - bottom * res, yaw), source=source)


def _masks(plan: OccupancyMap) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    known = ~plan.unknown
    occ = known & (plan.values < 128)
    return occ, known & ~occ, plan.unknown


def degrade(plan: OccupancyMap, kind: str, severity: float, *, seed: int = 0
            ) -> OccupancyMap:
    """The map a SLAM run with one kind of failure of a given severity would build.

    Parameters
    ----------
    plan : OccupancyMap
        The floor plan (:func:`floor_plan`, or a map: cells below 128 are walls).
    kind : {"drift", "doubling", "rotation", "specks", "superposed", "smear", "kinks", "gap"}
        The damage (module docstring); severity in the unit of :data:`DEGRADATIONS`.
    severity : float
        0 gives the plan back, cell for cell.
    seed : int, default 0
        Direction of the doubling, places of the specks, sign of the superposed rotation.

    Returns
    -------
    OccupancyMap
        On the plan's grid, grown where the damage moves cells beyond it.

    Examples
    --------
    >>> from slamq.synth import degrade, floor_plan
    >>> p = floor_plan(0)
    >>> bool((degrade(p, "drift", 0).values == p.values).all())
    True
    >>> degrade(p, "rotation", 10).shape > p.shape
    True
    """
    if kind not in DEGRADATIONS:
        raise ParamError(f"kind must be one of {', '.join(DEGRADATIONS)}, got {kind!r}")
    if not (isinstance(severity, (int, float)) and math.isfinite(severity)
            and severity >= 0):
        raise ParamError(f"severity must be a finite number >= 0, got {severity!r}")
    res = plan.resolution or 1.0
    occ, free, unk = _masks(plan)
    known = occ | free
    rows, cols = np.nonzero(known)
    h = plan.shape[0]
    u0, u1 = cols.min() * res, (cols.max() + 1) * res
    v0, v1 = (h - rows.max() - 1) * res, (h - rows.min()) * res
    uc, vc = (u0 + u1) / 2, (v0 + v1) / 2
    rng = np.random.default_rng(seed)
    label = f"{plan.source} {kind} {severity:g}"

    def ident(u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return u, v

    if kind == "rotation":
        a = math.radians(severity)

        def rot(u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            du, dv = u - uc, v - vc
            return (uc + math.cos(a) * du - math.sin(a) * dv,
                    vc + math.sin(a) * du + math.cos(a) * dv)
        return _draw(plan, [(occ, free, unk, rot)], label)
    if kind == "drift":
        eps = math.radians(severity) / 10.0  # heading error per metre travelled

        def bend(u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            s = u - u0  # distance travelled when the cell was seen
            th = eps * s
            px = s * np.sinc(th / np.pi)  # integral of cos(eps s)
            py = s * np.sin(th / 2) * np.sinc(th / (2 * np.pi))  # integral of sin(eps s)
            return u0 + px - np.sin(th) * (v - vc), vc + py + np.cos(th) * (v - vc)
        return _draw(plan, [(occ, free, unk, bend)], label)
    if kind == "doubling":
        phi = rng.uniform(0, 2 * math.pi)
        shift = (severity * math.cos(phi), severity * math.sin(phi))
        late = np.zeros_like(known)
        late[:, int(round(uc / res)):] = True

        def moved(u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            return u + shift[0], v + shift[1]
        return _draw(plan, [(occ, free, unk, ident),
                            (occ & late, free & late, unk & late, moved)], label)
    if kind == "gap":
        # a stretch of walls gone, seen as free space: the walls within a square of side
        # `severity` metres about a wall cell drawn at random (a leak, a missing wall)
        wr, wc = np.nonzero(occ)
        if severity == 0 or not len(wr):
            return _draw(plan, [(occ, free, unk, ident)], label)
        k = int(rng.integers(len(wr)))
        half = int(round(severity / res / 2))
        gone = np.zeros_like(occ)
        gone[max(0, wr[k] - half):wr[k] + half + 1, max(0, wc[k] - half):wc[k] + half + 1] = True
        gone &= occ
        return _draw(plan, [(occ & ~gone, free | gone, unk, ident)], label)
    if kind == "kinks":
        sign = 1.0 if rng.random() < 0.5 else -1.0
        a = sign * math.radians(severity)
        cuts = [u0 + (u1 - u0) * k / 3.0 for k in (1, 2)]
        col = [int(round(c / res)) for c in cuts]
        parts = []
        for k in range(3):
            band = np.zeros_like(known)
            band[:, (col[k - 1] if k else 0):(col[k] if k < 2 else None)] = True
            parts.append(band)

        def chain(k: int) -> Warp:
            def warp(u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
                for j in reversed(range(k)):  # the turn at the last cut first
                    du, dv = u - cuts[j], v - vc
                    u, v = (cuts[j] + math.cos(a) * du - math.sin(a) * dv,
                            vc + math.sin(a) * du + math.cos(a) * dv)
                return u, v
            return warp
        return _draw(plan, [(occ & b, free & b, unk & b, chain(k))
                            for k, b in enumerate(parts)], label)
    if kind in ("superposed", "smear"):
        late = np.zeros_like(known)
        late[:, int(round(uc / res)):] = True
        lr, lc = np.nonzero(known & late)
        pu = (lc.min() + lc.max() + 1) / 2 * res if len(lc) else uc
        pv = (h - (lr.min() + lr.max() + 1) / 2) * res if len(lr) else vc
        sign = 1.0 if rng.random() < 0.5 else -1.0

        def turned(a: float) -> Warp:
            def rot(u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
                du, dv = u - pu, v - pv
                return (pu + math.cos(a) * du - math.sin(a) * dv,
                        pv + math.sin(a) * du + math.cos(a) * dv)
            return rot
        if kind == "superposed":
            return _draw(plan, [(occ, free, unk, ident),
                                (occ & late, free & late, unk & late,
                                 turned(sign * math.radians(severity)))], label)
        # smear: the late walls at headings 0..severity, 0.5 degree apart at most
        steps = max(1, int(math.ceil(severity / 0.5)))
        none = np.zeros_like(known)
        layers = [(occ, free, unk, ident)] + [
            (occ & late, none, none, turned(sign * math.radians(severity) * k / steps))
            for k in range(1, steps + 1)]
        return _draw(plan, layers, label)
    # specks
    fr, fc = np.nonzero(free)
    n = int(round(severity * len(fr)))
    pick = rng.choice(len(fr), size=min(n, len(fr)), replace=False)
    noisy = occ.copy()
    noisy[fr[pick], fc[pick]] = True
    return _draw(plan, [(noisy, free & ~noisy, unk, ident)], label)


def series(plan: OccupancyMap, kind: str, severities: Sequence[float] | None = None, *,
           seed: int = 0) -> list[tuple[float, OccupancyMap]]:
    """``(severity, map)`` for each severity of one kind of damage.

    Examples
    --------
    >>> from slamq.synth import floor_plan, series
    >>> [s for s, _ in series(floor_plan(0), "specks")]
    [0.0, 0.001, 0.002, 0.005, 0.01, 0.02]
    """
    sev = SEVERITIES[kind] if severities is None and kind in SEVERITIES else severities
    return [(float(s), degrade(plan, kind, float(s), seed=seed)) for s in (sev or ())]
