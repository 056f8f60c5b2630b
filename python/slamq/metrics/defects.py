"""Defect detectors on one map: named SLAM failures, each flag with a place.

The paper's metrics (corners, occupied fraction, enclosed areas) are single numbers that
cannot say *what* is wrong with a map nor where, and they cannot see that a map is made of
two copies of the building. These detectors look for four typical failures of a SLAM run in
one occupancy grid, without ground truth (docs/validity.md, "Defect detectors", says how
well each one works on synthetic damage, on the ground-truth benchmark and on real maps):

- ``superposed``: two copies of (a part of) the building laid over each other at an angle
  (a failed loop closure, scan matching that diverged): a second strong wall direction
  (the wall-orientation histogram modulo the building's period, weighted by wall length,
  has two peaks more than ``superposed_min_separation`` apart) whose walls lie in the same
  places as the walls of the main direction (a building with an angled wing has its second
  direction somewhere else).
- ``doubled_walls``: parallel wall pairs a few centimetres apart (occupied, a free gap of
  ``doubled_min_gap``..``doubled_max_gap`` metres, occupied, across the walls) over a
  substantial wall length: a copy shifted by a few centimetres.
- ``smeared``: smeared or fan-shaped walls: occupied blobs and wedges thicker than
  ``smeared_min_thickness`` (distance transform of the occupied mask) that are not a solid
  rectangular or round object (furniture, pillars).
- ``fragmented``: the known area split into several sizeable disconnected pieces.

The building's period is that of its walls' symmetry (docs/spec.md 3a.2,
:func:`slamq.models.quality.wall_symmetry`): 60 degrees for a hexagonal building (walls 60
degrees apart: a clean hexagonal arena is not two copies turned 30 degrees against each
other), else 90.

Every detector takes an :class:`~slamq.OccupancyMap` and returns a list of
:class:`Defect` (empty when it sees nothing); :func:`detect_defects` runs them all. The
thresholds are rows of :data:`slamq.params.SETTINGS` (family ``defects``), in metres where
they are lengths, and so are the detectors' own small lengths (:data:`LINK`): a map
without a resolution is read as 0.05 m per cell. Only the quantisation floors stay in
cells (a gap of one cell, a wall a few cells thick, is the grid's own noise on any grid).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from contextvars import ContextVar
from dataclasses import asdict, dataclass
from typing import Any

import cv2
import numpy as np

from slamq import native
from slamq.errors import ParamError
from slamq.models import OccupancyMap
from slamq.models.quality import WALL_PERIODS, wall_symmetry
from slamq.params import SETTINGS

__all__ = ["DETECTORS", "LINK", "Defect", "detect_defects", "direction_separation",
           "doubled_walls", "fragmented", "smeared", "superposed", "wall_period"]

#: Metres per cell assumed for a map without a resolution.
DEFAULT_RESOLUTION = 0.05
#: The detectors' own small lengths, metres (one cell of a 0.05 m grid, where they were
#: set in cells; on a finer grid more cells, on a coarser one still one cell): the holes a
#: doubled stretch bridges and how far its gap centre moves from one cell to the next, the
#: gaps the smear closing fills, the smallest thick core and the outline's tolerance of
#: the object test.
LINK = 0.05
_S = SETTINGS


@dataclass(frozen=True)
class Defect:
    """One flag of a defect detector.

    Attributes
    ----------
    kind : str
        The detector: ``"superposed"``, ``"doubled_walls"``, ``"smeared"`` or
        ``"fragmented"``.
    score : float
        How strong the evidence is, in the detector's unit (``note`` says it); the flag was
        raised because it passed the detector's threshold.
    bbox : tuple of int
        ``(col0, row0, col1, row1)``: where, in the map image's pixel coordinates (row 0 at
        the top), the end exclusive.
    where_m : tuple of float
        ``(x, y)`` of the box's centre in the map frame, metres.
    note : str
        One line for people: what was seen, with the numbers.
    separation : float or None
        ``superposed`` only: degrees between the second wall direction and the first,
        folded to ``[0, period / 2]`` (0-45 degrees, 0-30 for a hexagonal map); the same
        for any turn of the map, so two maps' flags can be compared. None for the other
        kinds.

    Examples
    --------
    >>> d = Defect("fragmented", 0.4, (0, 0, 10, 20), (0.25, 0.5), "2 pieces")
    >>> d.to_dict()["bbox"], d.to_dict()["kind"], "separation" in d.to_dict()
    ([0, 0, 10, 20], 'fragmented', False)
    """

    kind: str
    score: float
    bbox: tuple[int, int, int, int]
    where_m: tuple[float, float]
    note: str
    separation: float | None = None

    def to_dict(self) -> dict[str, Any]:
        """``{"kind", "score", "bbox", "where_m", "note"}`` with plain lists and floats,
        and ``"separation"`` when there is one."""
        d = asdict(self)
        d["bbox"] = [int(v) for v in self.bbox]
        d["where_m"] = [float(v) for v in self.where_m]
        d["score"] = float(self.score)
        if self.separation is None:
            del d["separation"]
        else:
            d["separation"] = float(self.separation)
        return d


# ---------------------------------------------------------------------------- helpers

#: While :func:`detect_defects` runs on one map: what its detectors share (the masks, the
#: period, the wall directions), computed once for all of them. None outside it.
_SHARED: ContextVar[dict[Any, Any] | None] = ContextVar("slamq_defects_shared", default=None)


def _shared(key: tuple[Any, ...], make: Callable[[], Any]) -> Any:
    """``make()``, once per ``key`` while :func:`detect_defects` runs (every call
    otherwise). A key names its inputs by ``id``: the arrays live as long as that run."""
    memo = _SHARED.get()
    if memo is None:
        return make()
    if key not in memo:
        memo[key] = make()
    return memo[key]



def _res(m: OccupancyMap) -> float:
    return float(m.resolution) if m.resolution else DEFAULT_RESOLUTION


def _cells(metres: float, res: float) -> int:
    """``metres`` in cells of ``res``, at least 1 (:data:`LINK` is 1 cell at 0.05 m)."""
    return max(1, int(round(metres / res)))


def wall_period(m: OccupancyMap) -> float:
    """The period of a map's wall directions, degrees: 60 for a hexagonal map, else 90
    (rectilinear and irregular maps: docs/spec.md 3a.2).

    Examples
    --------
    >>> from slamq.synth import floor_plan
    >>> wall_period(floor_plan(1))
    90.0
    """
    def make() -> float:
        harmonics = native.wall_harmonics(np.ascontiguousarray(m.values, np.uint8),
                                          np.ascontiguousarray(m.unknown, bool))
        return WALL_PERIODS.get(wall_symmetry(harmonics)[0], 90.0)

    return float(_shared(("period", id(m)), make))


def _check(name: str, value: Any) -> float:
    s = _S[name]
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ParamError(f"{name} must be a number, got {value!r}") from None
    if isinstance(value, bool) or not math.isfinite(x) or (
            s.low is not None and x < s.low) or (s.high is not None and x > s.high):
        raise ParamError(f"{name} must be a finite number in [{s.low}, {s.high}], got "
                         f"{value!r}")
    return x


def _masks(m: OccupancyMap, occupied_threshold: float
           ) -> tuple[np.ndarray, np.ndarray, tuple[int, int]]:
    """``(occupied, free, (row0, col0))``: bool masks of the known cells' bounding box (with
    a 2-cell margin) and where it starts. A known cell is occupied when (255 - v) / 255 is
    above ``occupied_threshold`` (as :func:`slamq.compare`)."""
    thr = _check("occupied_threshold", occupied_threshold)

    def make() -> tuple[np.ndarray, np.ndarray, tuple[int, int]]:
        known = ~m.unknown
        r0, c0, r1, c1 = _known_box(known)
        known = known[r0:r1, c0:c1]
        occ = known & (m.values[r0:r1, c0:c1] < 255.0 * (1.0 - thr))
        return occ, known & ~occ, (r0, c0)

    occ, free, off = _shared(("masks", id(m), thr), make)
    return occ, free, off


def _known_box(known: np.ndarray) -> tuple[int, int, int, int]:
    rows = np.flatnonzero(known.any(axis=1))
    cols = np.flatnonzero(known.any(axis=0))
    if not len(rows):
        return (0, 0, known.shape[0], known.shape[1])
    h, w = known.shape
    return (max(0, int(rows[0]) - 2), max(0, int(cols[0]) - 2), min(h, int(rows[-1]) + 3),
            min(w, int(cols[-1]) + 3))


def _shift(bbox: tuple[int, int, int, int], off: tuple[int, int]
           ) -> tuple[int, int, int, int]:
    return (bbox[0] + off[1], bbox[1] + off[0], bbox[2] + off[1], bbox[3] + off[0])


#: Directions are measured on a grid of about this many metres per cell (finer maps are
#: pooled), so the measuring window is the same size in metres on every map.
_ORIENTATION_GRID = 0.05


def _coarse(occ: np.ndarray, res: float) -> tuple[np.ndarray, float, int]:
    """``occ`` max-pooled to about :data:`_ORIENTATION_GRID` per cell, its resolution and
    the pooling factor."""
    f = max(1, int(round(_ORIENTATION_GRID / res)))
    if f == 1:
        return occ, res, 1
    h, w = occ.shape
    pad = np.zeros((-(-h // f) * f, -(-w // f) * f), bool)
    pad[:h, :w] = occ
    return pad.reshape(pad.shape[0] // f, f, pad.shape[1] // f, f).any(axis=(1, 3)), \
        res * f, f


def _where(m: OccupancyMap, bbox: tuple[int, int, int, int]) -> tuple[float, float]:
    """Map-frame metres of the centre of a pixel box."""
    res = _res(m)
    h = m.shape[0]
    c = (bbox[0] + bbox[2]) / 2.0
    r = (bbox[1] + bbox[3]) / 2.0
    u, v = c * res, (h - r) * res
    x0, y0, yaw = m.origin
    cy, sy = math.cos(yaw), math.sin(yaw)
    return (round(x0 + cy * u - sy * v, 3), round(y0 + sy * u + cy * v, 3))


def _box(mask: np.ndarray) -> tuple[int, int, int, int]:
    rows = np.flatnonzero(mask.any(axis=1))
    cols = np.flatnonzero(mask.any(axis=0))
    if not len(rows):
        return (0, 0, 0, 0)
    return (int(cols[0]), int(rows[0]), int(cols[-1]) + 1, int(rows[-1]) + 1)


def _orientation(occ: np.ndarray, res: float) -> tuple[np.ndarray, np.ndarray]:
    """Per cell: the local wall direction modulo 180 degrees (``[0, 180)``, the gradient's
    direction: 0 for a wall along the rows' normal... i.e. 90 for a level wall) and its
    weight (the anisotropic energy of the structure tensor, about proportional to wall
    length). The mask is blurred first (sigma 2 cells) so that the staircase of a turned
    wall reads as its slope."""
    img = cv2.GaussianBlur(occ.astype(np.float32), (0, 0), 2.0)
    gx = cv2.Sobel(img, cv2.CV_32F, 1, 0, ksize=3)
    gy = cv2.Sobel(img, cv2.CV_32F, 0, 1, ksize=3)
    sigma = 3.0
    jxx = cv2.GaussianBlur(gx * gx, (0, 0), sigma)
    jyy = cv2.GaussianBlur(gy * gy, (0, 0), sigma)
    jxy = cv2.GaussianBlur(gx * gy, (0, 0), sigma)
    d = jxx - jyy
    weight = cv2.magnitude(d, 2.0 * jxy)
    angle = cv2.phase(d, 2.0 * jxy, angleInDegrees=True)  # [0, 360): twice the angle
    return angle * 0.5, weight


def _along(angle: np.ndarray, period: float) -> np.ndarray:
    """:func:`_orientation`'s angles as the walls' own directions where it matters: modulo
    90 degrees a wall and its gradient have one direction; modulo 60 they are 30 apart."""
    return angle if period == 90.0 else np.mod(angle + 90.0, 180.0)


_PER_CELL: float | None = None


def _weight_per_cell() -> float:
    """The orientation weight of one cell of length of a straight two-cell wall (the
    histogram's unit: divided by it, a weight is a wall length in cells)."""
    global _PER_CELL
    if _PER_CELL is None:
        occ = np.zeros((64, 400), bool)
        occ[31:33, 50:350] = True
        _, w = _orientation(occ, 0.05)
        _PER_CELL = float(w[:, 100:300].sum() / 200.0)
    return _PER_CELL


def _bins(period: float) -> int:
    """0.5 degree bins over ``[0, period)``."""
    return int(round(2 * period))


def _histogram(angle: np.ndarray, weight: np.ndarray, period: float = 90.0) -> np.ndarray:
    n = _bins(period)
    sel = weight > 1e-3 * (float(weight.max()) if weight.size else 0.0)
    b = np.minimum((np.mod(angle[sel], period) * (n / period)).astype(np.int64), n - 1)
    hist = np.bincount(b, weights=weight[sel], minlength=n)
    k = np.exp(-0.5 * (np.arange(-6, 7) / 2.0) ** 2)  # sigma 1 degree
    k /= k.sum()
    return np.convolve(np.concatenate([hist[-6:], hist, hist[:6]]), k, "valid")


def _circ(a: np.ndarray | float, b: float, period: float = 90.0) -> np.ndarray | float:
    d = np.abs(np.asarray(a) - b) % period
    return np.minimum(d, period - d)


def dominant_direction(m: OccupancyMap, *,
                       occupied_threshold: float = _S.occupied_threshold.default) -> float:
    """The main wall direction of a map, degrees counter-clockwise in ``[0, P)`` (the peak
    of the length-weighted orientation histogram modulo the map's period ``P``,
    :func:`wall_period`: 90 degrees, or 60 for a hexagonal map).

    Examples
    --------
    >>> from slamq.synth import degrade, floor_plan
    >>> round(dominant_direction(degrade(floor_plan(1), "rotation", 7)))
    7
    """
    occ, _, _ = _masks(m, occupied_threshold)
    period = wall_period(m)
    return float((period - _dominant(occ, _res(m), period)) % period)


def _dominant(occ: np.ndarray, res: float, period: float = 90.0) -> float:
    """The main wall direction as measured in the image (rows down), ``[0, period)``."""
    def make() -> float:
        angle, weight = _coarse_orientation(occ, res)[3:]
        angle = _along(angle, period)
        return float((np.argmax(_histogram(angle, weight, period)) + 0.5) * period
                     / _bins(period))

    return float(_shared(("dominant", id(occ), res, period), make))


def _coarse_orientation(occ: np.ndarray, res: float
                        ) -> tuple[np.ndarray, float, int, np.ndarray, np.ndarray]:
    """``occ`` pooled by :func:`_coarse` (the mask, its resolution, the pooling factor),
    and its :func:`_orientation` (angle, weight)."""
    def make() -> tuple[np.ndarray, float, int, np.ndarray, np.ndarray]:
        c, cres, f = _coarse(occ, res)
        return (c, cres, f, *_orientation(c, cres))

    c, cres, f, angle, weight = _shared(("orientation", id(occ), res), make)
    return c, cres, f, angle, weight


# ---------------------------------------------------------------------------- superposed


def superposed(m: OccupancyMap, *,
               superposed_min_separation: float = _S.superposed_min_separation.default,
               superposed_min_share: float = _S.superposed_min_share.default,
               superposed_min_length: float = _S.superposed_min_length.default,
               superposed_min_mixed: float = _S.superposed_min_mixed.default,
               superposed_min_square: float = _S.superposed_min_square.default,
               superposed_split_share: float = _S.superposed_split_share.default,
               superposed_split_length: float = _S.superposed_split_length.default,
               occupied_threshold: float = _S.occupied_threshold.default) -> list[Defect]:
    """Rotated copies laid over each other: a second wall direction in the same places.

    The wall-orientation histogram (structure tensor of the occupied mask, modulo the
    map's period, :func:`wall_period`: 90 degrees, 60 for a hexagonal map; weighted by wall
    length) must have a second peak at least
    ``superposed_min_separation`` degrees from the first, and either hold at least
    ``superposed_min_length`` metres of wall (occupied cells of that direction times the
    cell size) and at least ``superposed_min_share`` of the first peak's height
    (above the histogram's median), running both ways (the second direction and its
    perpendicular, or its copies 60 degrees on for a hexagonal map, the lesser at least
    ``superposed_min_square`` of the greater: a lone
    diagonal wall runs one way) with at least ``superposed_min_mixed`` of its walls in 2 m
    tiles that also hold walls of the first direction (a rotated copy laid over the
    original), or hold at least ``superposed_split_share`` of it over at least
    ``superposed_split_length`` metres wherever it lies (parts of the map turned against
    each other: scan matching that jumped). The second rule also flags a real building
    with a strong second direction (a wing at an angle holding a fifth of the main
    direction's walls); the verdict lifts such a flag where another program's map draws
    the same direction (``separation`` within 5 degrees where both maps' scans were
    scored, 3 without; docs/spec.md section 9). Walls
    turned by less than about 5 degrees are not told apart (a local direction is measured
    over about ten cells); :func:`doubled_walls` sees such copies as wedge-shaped wall
    pairs.

    Returns
    -------
    list of Defect
        At most one: score = the second direction's share of the first's peak, the box
        around the tiles where both directions meet, ``separation`` the degrees between
        the two directions (folded to at most half the period).

    Examples
    --------
    >>> from slamq.synth import degrade, floor_plan
    >>> [d.kind for d in superposed(degrade(floor_plan(3), "superposed", 10, seed=3))]
    ['superposed']
    >>> superposed(degrade(floor_plan(3), "rotation", 10))
    []
    """
    sep = _check("superposed_min_separation", superposed_min_separation)
    share_min = _check("superposed_min_share", superposed_min_share)
    length_min = _check("superposed_min_length", superposed_min_length)
    mixed_min = _check("superposed_min_mixed", superposed_min_mixed)
    square_min = _check("superposed_min_square", superposed_min_square)
    occ, _, off = _masks(m, occupied_threshold)
    split_min = _check("superposed_split_share", superposed_split_share)
    split_length = _check("superposed_split_length", superposed_split_length)
    period = wall_period(m)
    ev = _superposed_evidence(occ, _res(m), sep, period)
    if not ev:
        return []
    laid_over = ev["share"] >= share_min and ev["mixed"] >= mixed_min \
        and ev["square"] >= square_min and ev["length"] >= length_min
    split = ev["share"] >= split_min and ev["length"] >= split_length
    if not (laid_over or split):
        return []
    bbox = _shift(ev["bbox"], off)
    how = (f"{ev['mixed']:.0%} of it among main-direction walls" if laid_over else
           "the parts of the map turned against each other")
    note = (f"second wall direction {ev['a2']:.1f} deg beside {ev['a1']:.1f} deg "
            f"(mod {period:g}): "
            f"{ev['share']:.2f} of the main peak, {ev['length']:.1f} m of wall, {how}")
    return [Defect("superposed", round(ev["share"], 4), bbox, _where(m, bbox), note,
                   separation=direction_separation(ev["a1"], ev["a2"], period))]


def direction_separation(a1: float, a2: float, period: float = 90.0) -> float:
    """Degrees between two wall directions ``a1`` and ``a2`` (degrees, modulo ``period``),
    folded to ``[0, period / 2]`` and rounded to 0.01: the ``separation`` of a
    ``superposed`` flag, the same for any turn of the map.

    Examples
    --------
    >>> direction_separation(0.2, 59.2), direction_separation(10.0, 25.0, 60.0)
    (31.0, 15.0)
    """
    turn = abs(a2 - a1) % period
    return round(min(turn, period - turn), 2)


def _superposed_evidence(occ: np.ndarray, res: float, sep: float, period: float = 90.0
                         ) -> dict[str, Any]:
    """The numbers :func:`superposed` decides on (empty when there is no second peak)."""
    occ, res, f, angle2d, weight2d = _coarse_orientation(occ, res)
    angle2d = _along(angle2d, period)
    h, w = occ.shape
    # from here on only the cells near walls (weight above a floor), as flat arrays
    wmax = float(weight2d.max()) if weight2d.size else 0.0
    sel = np.flatnonzero(weight2d.ravel() > 1e-3 * wmax)
    angle = angle2d.ravel()[sel]
    weight = weight2d.ravel()[sel]
    hist = _histogram(angle, weight, period)
    nbins = _bins(period)
    centres = (np.arange(nbins) + 0.5) * period / nbins
    i1 = int(np.argmax(hist))
    a1 = float(centres[i1])
    base = float(np.median(hist))
    h1 = float(hist[i1]) - base
    if h1 <= 0:
        return {}
    local_max = (hist >= np.roll(hist, 1)) & (hist >= np.roll(hist, -1))
    cand = np.flatnonzero(local_max & (_circ(centres, a1, period) >= sep))
    if not len(cand):
        return {}
    i2 = int(cand[np.argmax(hist[cand])])
    a2 = float(centres[i2])
    # the valley between the peaks (the shorter arc), so a shoulder is not a peak
    lo, hi = sorted((i1, i2))
    arc = hist[lo:hi + 1] if hi - lo <= nbins // 2 else np.concatenate([hist[hi:],
                                                                       hist[:lo + 1]])
    prominence = float(hist[i2]) - max(float(arc.min()), base)
    share = prominence / h1
    band = 1.5
    in_b = _circ(angle, a2, period) <= band
    wa = np.where(_circ(angle, a1, period) <= band, weight, 0.0)
    wb = np.where(in_b, weight, 0.0)
    # both ways: the second direction and its perpendicular, or its copies 60 degrees on
    # (angle modulo 180)
    d180 = np.abs(np.mod(angle - a2, 180.0))
    one = float(wb[in_b & ((d180 <= band) | (d180 >= 180.0 - band))].sum())
    other = float(wb.sum()) - one
    square = min(one, other) / max(one, other, 1e-9)
    # the second direction's walls above the histogram's floor, in metres of one-cell wall
    # (occupied cells of that direction times the cell size: a thin, broken wall counts
    # what it holds)
    cells = float(np.count_nonzero(occ.ravel()[sel] & in_b
                                   & (weight > 0.05 * _weight_per_cell())))
    length = cells * (1.0 - base / max(float(hist[i2]), 1e-9)) * res
    tile = max(4, int(round(2.0 / res)))
    th, tw = -(-h // tile), -(-w // tile)
    tidx = (sel // w) // tile * tw + (sel % w) // tile
    ta = np.bincount(tidx, weights=wa, minlength=th * tw).reshape(th, tw)
    tb = np.bincount(tidx, weights=wb, minlength=th * tw).reshape(th, tw)
    per_tile = _weight_per_cell() * tile * 0.3  # 0.3 m of wall in the tile
    mixed = (tb >= per_tile) & (ta >= per_tile) & (ta >= 0.25 * tb) & (tb >= 0.25 * ta)
    mixed_share = float(tb[mixed].sum() / max(float(tb.sum()), 1e-9))
    where = mixed if mixed.any() else tb >= per_tile
    if where.any():
        r, c = np.nonzero(where)
        bbox = (int(c.min()) * tile, int(r.min()) * tile, min(w, (int(c.max()) + 1) * tile),
                min(h, (int(r.max()) + 1) * tile))
    else:
        bbox = (0, 0, w, h)
    bbox = (bbox[0] * f, bbox[1] * f, bbox[2] * f, bbox[3] * f)
    return {"a1": a1, "a2": a2, "share": share, "length": length, "mixed": mixed_share,
            "square": square, "bbox": bbox}


# ---------------------------------------------------------------------------- doubled walls


def _pairs(occ: np.ndarray, free: np.ndarray, gmin: int, gmax: int, thick: int
           ) -> np.ndarray:
    """The gap centres (uint8 mask) of occupied-free-occupied runs down the columns: an
    occupied cell, ``g`` free cells above it (``gmin <= g <= gmax``), then an occupied cell,
    both occupied runs at most ``thick`` cells thick (two thin walls, not the holes of one
    thick, noisy wall). Shifted boolean planes, one per gap length and thickness step."""
    h, w = occ.shape
    nonocc = ~occ
    thin_dn = np.zeros((h, w), bool)  # a non-occupied cell within thick cells below
    thin_up = np.zeros((h, w), bool)  # ... above
    for k in range(1, min(thick, h - 1) + 1):
        thin_dn[:h - k] |= nonocc[k:]
        thin_up[k:] |= nonocc[:h - k]
    ok_dn = occ & thin_dn  # the lower wall's top cell at r
    ok_up = occ & thin_up  # the upper wall's bottom cell at p
    centre = np.zeros((h, w), bool)
    allfree = free.copy()  # cells r-1 .. r-g all free, stored at row r
    allfree[1:] = free[:-1]
    allfree[0] = False
    for g in range(1, min(gmax, h - 2) + 1):
        if g > 1:
            allfree[g:] &= free[:h - g]
            allfree[:g] = False
        if g < gmin:
            continue
        cand = allfree[g + 1:] & ok_dn[g + 1:] & ok_up[:h - g - 1]  # rows r = g+1 ..
        half = (g + 1) // 2
        centre[g + 1 - half:h - half] |= cand
    return centre.view(np.uint8)


def _rotate(mask: np.ndarray, angle: float) -> tuple[np.ndarray, np.ndarray]:
    """``mask`` turned by ``angle`` degrees about its centre (nearest cell, grown to hold
    it), and the 2x3 matrix back from the turned image to the original."""
    h, w = mask.shape
    a = math.radians(angle)
    nw = int(math.ceil(abs(w * math.cos(a)) + abs(h * math.sin(a))))
    nh = int(math.ceil(abs(w * math.sin(a)) + abs(h * math.cos(a))))
    fwd = cv2.getRotationMatrix2D((w / 2.0, h / 2.0), angle, 1.0)
    fwd[0, 2] += (nw - w) / 2.0
    fwd[1, 2] += (nh - h) / 2.0
    out = cv2.warpAffine(mask.astype(np.uint8), fwd, (nw, nh), flags=cv2.INTER_NEAREST)
    return out.astype(bool), cv2.invertAffineTransform(fwd)


#: doubled_walls: a gap of one cell is quantisation, not a second wall, whatever the
#: resolution; smeared: a wall this many cells thick is still drawn by sensor noise.
_MIN_GAP_CELLS, _MIN_THICK_CELLS = 2, 6
#: doubled_walls: each wall of a pair is at most this thick (metres, and at least this
#: many cells): a doubled wall is two thin walls; a thick band with holes is one noisy wall.
_THIN_WALL, _MIN_WALL_CELLS = 0.2, 3


def doubled_walls(m: OccupancyMap, *, doubled_min_gap: float = _S.doubled_min_gap.default,
                  doubled_max_gap: float = _S.doubled_max_gap.default,
                  doubled_min_length: float = _S.doubled_min_length.default,
                  doubled_min_share: float = _S.doubled_min_share.default,
                  doubled_min_run: float = _S.doubled_min_run.default,
                  occupied_threshold: float = _S.occupied_threshold.default) -> list[Defect]:
    """Parallel wall pairs a few centimetres apart: a copy of the walls shifted a little.

    The map is turned to its main wall direction; down every column and along every row
    (a hexagonal map, :func:`wall_period`: turned to each of its three directions, down
    every column), an occupied cell, a gap of ``doubled_min_gap``..``doubled_max_gap``
    metres of free cells (all seen free: the two sides of one real wall have unknown cells
    between them), then occupied again is one pair (the gap is at least 2 cells on any
    grid; each wall of the pair at most 0.2 m thick, and 3 cells, so the holes of one thick,
    noisy wall are not a pair). Pairs in a row along a wall (the gap centre moving by at
    most :data:`LINK` from one column to the next, holes of up to :data:`LINK` bridged: one
    cell at 0.05 m) for at least ``doubled_min_run`` metres are a doubled stretch; the map
    is flagged when the stretches add up to ``doubled_min_length`` metres and to
    ``doubled_min_share`` of the map's wall length (its occupied cells times the cell
    size; 0, no share, by default). Furniture and fittings beside walls make short pairs in
    every building, more the larger it is: 4-6.5 m in the 950 m of walls of the Intel
    lab's GMapping maps, which are sound. A share of 0.01 lifts those flags and keeps every
    flag on generated damage, but it also lifts one on a broken real map (0.97%), so it is
    not the default (docs/validity.md, "Doubled walls as a share of the map's walls").

    Returns
    -------
    list of Defect
        At most one: score = doubled wall length in metres, box around the stretches.

    Examples
    --------
    >>> from slamq.synth import degrade, floor_plan
    >>> [d.kind for d in doubled_walls(degrade(floor_plan(3), "doubling", 0.3, seed=3))]
    ['doubled_walls']
    >>> doubled_walls(floor_plan(3))
    []
    """
    gmin_m = _check("doubled_min_gap", doubled_min_gap)
    gmax_m = _check("doubled_max_gap", doubled_max_gap)
    min_len = _check("doubled_min_length", doubled_min_length)
    min_share = _check("doubled_min_share", doubled_min_share)
    min_run = _check("doubled_min_run", doubled_min_run)
    occ, free, off = _masks(m, occupied_threshold)
    res = _res(m)
    gmin = max(_MIN_GAP_CELLS, int(round(gmin_m / res)))
    gmax = max(gmin, int(round(gmax_m / res)))
    if gmax > 250:
        raise ParamError(f"doubled_max_gap is {gmax} cells; at most 250")
    period = wall_period(m)
    a = _dominant(occ, res, period)  # measured in the image (rows down): clockwise as seen
    a = a - period if a > period / 2 else a
    # the turns that bring the building's wall directions level: a rectilinear one read
    # down the columns and along the rows once turned; a hexagonal one turned three times
    # (its directions 60 degrees apart), read down the columns each time
    turns = [(a, (0, 1))] if period != 60.0 else [
        ((a + k * 60.0 + 90.0) % 180.0 - 90.0, (0,)) for k in range(3)]
    run = max(2, int(round(min_run / res)))
    thick = max(_MIN_WALL_CELLS, int(round(_THIN_WALL / res)))
    link = 2 * _cells(LINK, res) + 1  # 3 cells at 0.05 m
    total = 0.0
    points = []
    stretches = 0
    for turn, axes in turns:
        if abs(turn) > 1.0:
            # a wall turned clockwise by a (as seen) is level after turning the image by a
            # counter-clockwise (cv2's positive angle)
            o, back = _rotate(occ, turn)
            f, _ = _rotate(free, turn)
        else:
            o, f, back = occ, free, None
        boxes = []
        for axis in axes:
            oo, ff = (o, f) if axis == 0 else (o.T, f.T)
            centre = _pairs(np.ascontiguousarray(oo), np.ascontiguousarray(ff), gmin, gmax,
                            thick)
            # stretches: gap centres in a row along the wall (moving by LINK at most from
            # one column to the next), bridging holes of LINK
            sel = cv2.dilate(centre, np.ones((link, 1), np.uint8))
            sel = cv2.morphologyEx(sel, cv2.MORPH_CLOSE, np.ones((1, link), np.uint8))
            r0, c0, r1, c1 = _known_box(sel > 0)  # label only where there are pairs
            n, _, stats, _ = cv2.connectedComponentsWithStats(
                np.ascontiguousarray(sel[r0:r1, c0:c1]), connectivity=8)
            stats[:, 0] += c0
            stats[:, 1] += r0
            for k in range(1, n):
                x, y, bw, bh, _ = stats[k]
                if bw >= run:
                    total += bw * res
                    boxes.append((x, y, x + bw, y + bh) if axis == 0 else
                                 (y, x, y + bh, x + bw))
        if not boxes:
            continue
        stretches += len(boxes)
        b = np.array(boxes, float)
        corners = np.array([[b[:, 0].min(), b[:, 1].min()], [b[:, 2].max(), b[:, 1].min()],
                            [b[:, 0].min(), b[:, 3].max()], [b[:, 2].max(), b[:, 3].max()]])
        if back is not None:
            corners = corners @ back[:, :2].T + back[:, 2]
        points.append(corners)
    walls = float(np.count_nonzero(occ)) * res
    if total < min_len or total < min_share * walls or not points:
        return []
    corners = np.concatenate(points)
    h, w = occ.shape
    bbox = _shift((int(max(0, corners[:, 0].min())), int(max(0, corners[:, 1].min())),
                   int(min(w, math.ceil(corners[:, 0].max()))),
                   int(min(h, math.ceil(corners[:, 1].max())))), off)
    note = (f"{total:.1f} m of parallel wall pairs {gmin * res:.2f}-{gmax * res:.2f} m apart "
            f"({gmin}-{gmax} cells; {stretches} stretches of at least {min_run:g} m; "
            f"{total / max(walls, 1e-9):.1%} of {walls:.0f} m of walls)")
    return [Defect("doubled_walls", round(total, 3), bbox, _where(m, bbox), note)]


# ---------------------------------------------------------------------------- smeared


def smeared(m: OccupancyMap, *, smeared_min_thickness: float = _S.smeared_min_thickness.default,
            smeared_min_area: float = _S.smeared_min_area.default,
            occupied_threshold: float = _S.occupied_threshold.default) -> list[Defect]:
    """Smeared or fan-shaped walls: thick occupied blobs and wedges.

    The occupied mask (closed by :data:`LINK`, one cell at 0.05 m, so a fuzzy band of
    occupied and free cells counts as one blob) is measured by its distance transform: the
    cells deeper than half of ``smeared_min_thickness`` (and than 3 cells: noise alone draws
    walls a few cells thick on a coarse grid) form thick cores (of at least three cells of
    0.05 m). A core that is a solid rectangle or disc (its area at least 0.8 of its rotated
    bounding rectangle's, or 0.7 and nearly round: furniture, pillars) or whose outline
    runs along the building's directions (boxes side by side) is an object, not a smear.
    The map is flagged when the other cores cover ``smeared_min_area`` square metres.

    Returns
    -------
    list of Defect
        At most one: score = the thick cores' area in square metres, box around them.

    Examples
    --------
    >>> from slamq.synth import degrade, floor_plan
    >>> [d.kind for d in smeared(degrade(floor_plan(3), "smear", 10, seed=3))]
    ['smeared']
    >>> smeared(floor_plan(3))
    []
    """
    thick_m = _check("smeared_min_thickness", smeared_min_thickness)
    area_min = _check("smeared_min_area", smeared_min_area)
    occ, _, off = _masks(m, occupied_threshold)
    res = _res(m)
    side = 2 * _cells(LINK, res) + 1  # 3 cells at 0.05 m
    closed = cv2.morphologyEx(occ.astype(np.uint8), cv2.MORPH_CLOSE,
                              np.ones((side, side), np.uint8))
    dt = cv2.distanceTransform(closed, cv2.DIST_L2, 3)
    core = (dt >= max(thick_m / res, _MIN_THICK_CELLS) / 2.0).astype(np.uint8)
    if not core.any():
        return []
    n, lab, stats, _ = cv2.connectedComponentsWithStats(core, connectivity=8)
    keep = np.zeros(n, bool)
    axis = None
    period = 90.0
    link = max(1.0, LINK / res)  # 1 cell at 0.05 m, never less
    min_cells = int(round(3 * link * link))
    for k in range(1, n):
        x, y, bw, bh, area = stats[k]
        if area < min_cells:
            continue
        blob = (lab[y:y + bh, x:x + bw] == k).astype(np.uint8)
        (_, _), (rw, rh), _ = cv2.minAreaRect(cv2.findNonZero(blob))
        fill = area / ((rw + 1.0) * (rh + 1.0))
        round_ = min(rw, rh) + 1.0 >= 0.8 * (max(rw, rh) + 1.0)
        if fill >= 0.8 or (round_ and fill >= 0.7):
            continue  # a solid object: furniture, a pillar
        if axis is None:
            period = wall_period(m)
            axis = _dominant(occ, res, period)
        if _rectilinear(blob, axis, period, link) >= 0.85:
            continue  # boxes side by side or against a wall, square to the building
        keep[k] = True
    mask = keep[lab]
    area = float(np.count_nonzero(mask)) * res * res
    if area < area_min:
        return []
    bbox = _shift(_box(mask), off)
    note = (f"{area:.2f} m2 of wall thicker than {thick_m:g} m in "
            f"{int(keep.sum())} blobs that are not solid objects")
    return [Defect("smeared", round(area, 4), bbox, _where(m, bbox), note)]


def _rectilinear(blob: np.ndarray, axis: float, period: float = 90.0,
                 epsilon: float = 1.0) -> float:
    """The share of a blob's outline (a polygon within ``epsilon`` cells) that runs along
    the building's directions (``axis``, measured in the image as :func:`_dominant` gives
    it, modulo ``period``: and its perpendicular, or its copies 60 degrees on, within 10
    degrees).

    Examples
    --------
    >>> import cv2, numpy as np
    >>> blob = np.zeros((200, 200), np.uint8)
    >>> blob[50:150, 50:80] = 1
    >>> blob[120:150, 50:150] = 1                   # an L of two boxes
    >>> turn = cv2.getRotationMatrix2D((100, 100), 12, 1.0)  # 12 degrees anticlockwise
    >>> b = cv2.warpAffine(blob, turn, (200, 200), flags=cv2.INTER_NEAREST)
    >>> round(_rectilinear(b, -12.0), 2), round(_rectilinear(b, 12.0), 2)
    (1.0, 0.0)
    """
    contours, _ = cv2.findContours(blob, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    along = total = 0.0
    for c in contours:
        poly = cv2.approxPolyDP(c, epsilon, True).reshape(-1, 2).astype(float)
        d = np.roll(poly, -1, axis=0) - poly
        length = np.hypot(d[:, 0], d[:, 1])
        # measured in the image (rows down, clockwise as seen), as ``axis`` is
        # (:func:`_dominant`); counter-clockwise, atan2(-dy, dx), a building turned by t
        # had its outlines at -t against an axis at t
        ang = np.degrees(np.arctan2(d[:, 1], d[:, 0]))
        along += float(length[_circ(ang, axis, period) <= 10.0].sum())
        total += float(length.sum())
    return along / total if total else 1.0


# ---------------------------------------------------------------------------- fragmented


def fragmented(m: OccupancyMap, *, fragment_min_area: float = _S.fragment_min_area.default,
               fragment_min_share: float = _S.fragment_min_share.default) -> list[Defect]:
    """The known area split into several sizeable disconnected pieces.

    Known cells are joined across gaps of up to 0.2 m (unknown wall cells, thin unseen
    strips), then labelled; a piece is sizeable when it holds at least
    ``fragment_min_area`` square metres and ``fragment_min_share`` of the known area. The
    map is flagged when there are two sizeable pieces or more.

    Returns
    -------
    list of Defect
        At most one: score = the known share outside the largest piece, box around the
        other sizeable pieces.

    Examples
    --------
    >>> from slamq.synth import degrade, floor_plan
    >>> [d.kind for d in fragmented(degrade(floor_plan(3), "doubling", 30, seed=3))]
    ['fragmented']
    >>> fragmented(floor_plan(3))
    []
    """
    area_min = _check("fragment_min_area", fragment_min_area)
    share_min = _check("fragment_min_share", fragment_min_share)
    res = _res(m)
    known = (~m.unknown).astype(np.uint8)
    total = int(known.sum())
    if total == 0:
        return []
    k = max(1, int(round(0.1 / res)))
    joined = cv2.dilate(known, np.ones((2 * k + 1, 2 * k + 1), np.uint8))
    n, lab = cv2.connectedComponents(joined, connectivity=8)
    counts = np.bincount(lab[known > 0], minlength=n)
    counts[0] = 0
    big = np.flatnonzero((counts * res * res >= area_min) & (counts >= share_min * total))
    if len(big) < 2:
        return []
    order = big[np.argsort(-counts[big])]
    others = np.isin(lab, order[1:]) & (known > 0)
    share = 1.0 - float(counts[order[0]]) / total
    bbox = _box(others)
    note = (f"{len(big)} disconnected known pieces of at least {area_min:g} m2; "
            f"{share:.0%} of the known area lies outside the largest")
    return [Defect("fragmented", round(share, 4), bbox, _where(m, bbox), note)]


#: The detectors by name, in the order :func:`detect_defects` runs them.
DETECTORS = {"superposed": superposed, "doubled_walls": doubled_walls, "smeared": smeared,
             "fragmented": fragmented}


def detect_defects(m: OccupancyMap, detectors: Iterable[str] | None = None,
                   **settings: Any) -> list[Defect]:
    """Every detector's flags on one map.

    Parameters
    ----------
    m : OccupancyMap
    detectors : iterable of str, optional
        Names of :data:`DETECTORS` to run (default all).
    **settings
        Thresholds (rows of :data:`slamq.params.SETTINGS`, family ``defects``, and
        ``occupied_threshold``); each goes to the detectors that take it.

    Returns
    -------
    list of Defect
        Empty for a map in which no detector sees anything.

    Examples
    --------
    >>> from slamq.synth import degrade, floor_plan
    >>> detect_defects(floor_plan(2))
    []
    >>> [d.kind for d in detect_defects(degrade(floor_plan(2), "doubling", 30, seed=2),
    ...                                 ["fragmented"])]
    ['fragmented']
    """
    import inspect

    names = list(DETECTORS) if detectors is None else list(detectors)
    unknown = [n for n in names if n not in DETECTORS]
    if unknown:
        raise ParamError(f"unknown detector(s) {', '.join(unknown)}; known: "
                         f"{', '.join(DETECTORS)}")
    known = {p for fn in DETECTORS.values() for p in inspect.signature(fn).parameters}
    extra = sorted(set(settings) - known)
    if extra:
        raise ParamError(f"unknown setting(s) {', '.join(extra)} for the defect detectors")
    out: list[Defect] = []
    token = _SHARED.set({})  # the masks, period and directions, once for every detector
    try:
        for name in names:
            fn = DETECTORS[name]
            params = inspect.signature(fn).parameters
            out.extend(fn(m, **{k: v for k, v in settings.items() if k in params}))
    finally:
        _SHARED.reset(token)
    return out
