"""``MapQuality``: the three map metrics of one map (SPEC sections 2-4), built from the
integers both implementations (the Rust core and :mod:`slamq.metrics.reference`) produce."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, fields
from typing import Any

from slamq.columns import computed_columns, group_names
from slamq.params import Params

__all__ = ["HEXAGONAL_MARGIN", "MIN_RESULTANT", "WALL_PERIODS", "MapQuality",
           "facts_from_counts", "map_facts", "shade_source", "wall_symmetry"]

#: The wall-direction classes with a period (degrees): their wall angle is taken modulo it
#: (docs/spec.md 3a.2). A third class, ``irregular``, has none: its angle is not compared.
WALL_PERIODS: dict[str, float] = {"rectilinear": 90.0, "hexagonal": 60.0}
#: A class needs the resultant of its harmonic (its share of the gradient weight that
#: agrees on one direction modulo the period) to be at least this.
MIN_RESULTANT = 0.1
#: Hexagonal needs the sixth harmonic's resultant at least this many times the fourth's.
HEXAGONAL_MARGIN = 2.0


def wall_symmetry(harmonics: Sequence[int] | None, angle4: float = math.nan
                  ) -> tuple[str, float]:
    """The symmetry class of a map's walls and its wall angle modulo the class's period,
    from the wall-direction sums of docs/spec.md 3a.2.

    ``harmonics`` = ``(re4, im4, re6, im6, weight)``: the sums of ``g^4/|g|^3``,
    ``g^6/|g|^5`` and ``|g|`` over the map's Sobel gradients ``g``. With
    ``R4 = |re4 + i im4| / weight`` and ``R6 = |re6 + i im6| / weight`` (1 when every
    gradient agrees on one direction modulo 90, respectively 60 degrees; 0 for walls in
    every direction): ``rectilinear`` when ``R4 >= R6`` and ``R4 >= MIN_RESULTANT``;
    ``hexagonal`` (walls 60 degrees apart: hexagons, triangles) when
    ``R6 >= HEXAGONAL_MARGIN * R4`` and ``R6 >= MIN_RESULTANT``; ``irregular`` otherwise
    (no direction period, or one that is not clear). A rectilinear building whose walls
    run mostly one way has an ``R6`` as well (the imbalance of its two directions), but
    never above its ``R4``; a hexagonal one has ``R4`` only from the imbalance of its three.

    The angle, degrees: ``angle4`` (radians, ``atan2(im4, re4) / 4``, the angle the
    canonical map is turned by) for ``rectilinear`` and ``irregular``; for ``hexagonal``,
    ``atan2(-im6, -re6) / 6`` (a wall's gradient is perpendicular to it, which turns the
    sixth harmonic by 540 degrees), in (-30, 30]. Image axes, as the wall angle.
    ``harmonics`` None (an older core): ``("", angle4)`` in degrees.

    Examples
    --------
    >>> wall_symmetry((1000, 0, 40, 0, 1100), 0.0)
    ('rectilinear', 0.0)
    >>> c, a = wall_symmetry((30, 0, 0, -900, 1000), 0.0)
    >>> c, round(a, 6)
    ('hexagonal', 15.0)
    >>> wall_symmetry((50, 0, 60, 0, 1000), 0.0)[0]
    'irregular'
    """
    if harmonics is None:
        return "", math.degrees(float(angle4))
    re4, im4, re6, im6, weight = (int(v) for v in harmonics)
    deg4 = math.degrees(float(angle4)) if math.isfinite(angle4) else math.nan
    if weight <= 0:
        return "irregular", deg4
    r4 = math.hypot(re4, im4) / weight
    r6 = math.hypot(re6, im6) / weight
    if r4 >= r6 and r4 >= MIN_RESULTANT:
        return "rectilinear", deg4
    if r6 >= HEXAGONAL_MARGIN * r4 and r6 >= MIN_RESULTANT:
        return "hexagonal", math.degrees(math.atan2(-im6, -re6) / 6.0)
    return "irregular", deg4


def shade_source(grid: Any) -> Any:
    """The array whose values give a map's unknown cells their shade (``saver`` of
    :func:`map_facts`): the loader's pixels (``meta["pixels"]``) when they differ from the
    values (a YAML's thresholds, ``negate``), else None (the values themselves).

    Examples
    --------
    >>> import numpy as np
    >>> from slamq import load_map
    >>> shade_source(load_map(np.array([[0, 205]], np.uint8))) is None
    True
    """
    import numpy as np

    pixels = (getattr(grid, "meta", {}) or {}).get("pixels")
    if (isinstance(pixels, np.ndarray) and pixels.dtype == np.uint8
            and pixels.shape == grid.values.shape and pixels is not grid.values):
        return np.ascontiguousarray(pixels)
    return None


def map_facts(grid: Any) -> dict[str, Any]:
    """What a map's numbers depend on besides the place: its saver and canvas, for the
    comparability checks (``saver``, ``flags``, ``known_box_m2`` of :class:`MapQuality`).

    ``saver`` is ``mode/levels/unknown shade``: the YAML mode (or how the map was loaded),
    ``trinary`` when the known cells hold at most 3 grey levels else ``graded``, and the
    most common pixel value of the unknown cells (``-`` when none). ``flags`` joins the
    loader's flags (``yaml_beside``: a bare image whose YAML is beside it; ``screenshot``;
    ``mostly_unknown``) with ``;``. ``known_box_m2`` is the area of the known cells'
    bounding box (NaN without a resolution).

    This is the reference, with OpenCV's histograms and bounding box; ``slamq.evaluate``
    takes the same counts from the Rust core's histogram pass (:func:`facts_from_counts`),
    and ``verify=True`` checks that they agree.

    Examples
    --------
    >>> import numpy as np
    >>> from slamq import load_map
    >>> m = load_map(np.array([[0, 205], [254, 254]], np.uint8))
    >>> f = map_facts(m)
    >>> f["saver"], f["flags"]
    ('trinary/trinary/unknown 205', '')
    """
    import cv2
    import numpy as np

    values = np.ascontiguousarray(grid.values, np.uint8)
    unknown = np.ascontiguousarray(grid.unknown, bool).view(np.uint8)
    bins = ([0], None, [256], [0, 256])
    total = cv2.calcHist([values], bins[0], None, *bins[2:]).ravel()
    unk = cv2.calcHist([values], bins[0], unknown, *bins[2:]).ravel()
    levels = int(np.count_nonzero(total - unk))
    shade = None
    if unk.sum() > 0:
        pixels = shade_source(grid)
        if pixels is not None:
            unk = cv2.calcHist([pixels], bins[0], unknown, *bins[2:]).ravel()
        shade = int(unk.argmax())
    x, y, box_w, box_h = cv2.boundingRect(np.equal(unknown, 0).view(np.uint8))
    box = (y, y + box_h, x, x + box_w) if box_w else None
    return facts_from_counts(grid, levels, shade, box)


def facts_from_counts(grid: Any, levels: int, shade: int | None,
                      box: tuple[int, int, int, int] | None) -> dict[str, Any]:
    """:func:`map_facts` from its counts: the number of distinct values of the known cells,
    the unknown cells' commonest shade (None without unknown cells) and the known cells'
    bounding box ``(r0, r1, c0, c1)`` (None without known cells).

    Both implementations pass here with the map, so the values of the registered map
    columns that have a computation (:func:`slamq.columns.register_column`) are computed
    here too, as ``extra`` (empty without such a column).

    Examples
    --------
    >>> import numpy as np
    >>> from slamq import OccupancyMap
    >>> m = OccupancyMap(np.zeros((4, 4), np.uint8), np.zeros((4, 4), bool), resolution=0.5)
    >>> facts_from_counts(m, 1, None, (0, 4, 1, 3))["known_box_m2"]
    2.0
    """
    import math

    meta = getattr(grid, "meta", {}) or {}
    mode = meta.get("mode") or meta.get("kind") or "array"
    box_m2 = math.nan
    if box is not None and grid.resolution is not None:
        r0, r1, c0, c1 = box
        box_m2 = float((r1 - r0) * (c1 - c0)) * float(grid.resolution) ** 2
    return {
        "saver": f"{mode}/{'graded' if levels > 3 else 'trinary'}/unknown "
                 f"{'-' if shade is None else shade}",
        "flags": ";".join(meta.get("flags", [])),
        "known_box_m2": box_m2,
        "extra": {c.name: c.compute(grid) for c in computed_columns()  # type: ignore[misc]
                  },
    }


@dataclass(frozen=True)
class MapQuality:
    """The three metrics of one map (docs/spec.md sections 2-4) and the parameters used.

    Attributes
    ----------
    source : str
        The map's path, or ``"<array>"``.
    height, width : int
        Map size in cells.
    total, known, unknown, occupied, free : int
        Cell counts. ``free = known - occupied``; ``total = known + unknown``.
    occupied_fraction : float
        ``occupied / known`` (NaN when no cell is known): the canvas-independent figure.
    proportion : float
        ``occupied / (free + unknown)``: the paper's Fig. 5 ratio (canvas dependent).
    threshold : float
        Mean occupancy probability of the known cells, ``sum(255 - v) / (255 * known)``.
    corners : int
        Corner count (LoG structure mask + Harris), SPEC section 3.
    enclosed_areas : int
        Largest number of enclosed free regions over the unknown-value sweep, SPEC section 4.
    enclosed_unknown_value : int
        The smallest unknown value ``u`` reaching ``enclosed_areas``.
    resolution : float or None
        Metres per cell of the map (None when it has none, e.g. a bare array).
    known_area_m2 : float
        ``known * resolution**2``, the explored area (NaN without a resolution): maps of one
        place saved at different resolutions compare on it, not on ``known``.
    corners_canonical : int or None
        SPEC section 3a: the corner count of the map turned to its dominant wall direction
        and resampled to ``params.canonical_resolution`` (None when that is 0, the default,
        or when the canonical map would exceed 2**30 cells). Compare maps of different
        orientation or resolution on this (``canonical_resolution=0.07``), not on
        ``corners``.
    wall_angle : float
        The dominant wall direction modulo the period of the map's ``wall_symmetry``, in
        degrees (image axes: positive turns +x towards +y, rows down); always computed
        (SPEC 3a.2): in (-45, 45] for a rectilinear or irregular map (the angle the
        canonical map is turned by), in (-30, 30] for a hexagonal one.
    wall_symmetry : str
        ``"rectilinear"`` (walls 90 degrees apart), ``"hexagonal"`` (60 degrees apart) or
        ``"irregular"`` (neither): :func:`wall_symmetry`. Only maps of one periodic class
        have comparable wall angles.
    saver, flags, known_box_m2 : str, str, float
        How the map was saved and loaded, and the area of its known cells' bounding box:
        see :func:`map_facts`. Maps ranked together should agree on these.
    curve : tuple of int or None
        ``count_u`` for every ``u`` in ``params.sweep_values`` (when asked for).
    params : Params
        The parameters used.
    extra : dict
        The values of the registered map columns (:func:`slamq.columns.register_column`),
        by name; empty without one. :meth:`to_dict` puts them after ``curve``.

    Examples
    --------
    >>> import numpy as np
    >>> import slamq
    >>> room = np.full((7, 7), 205, np.uint8)
    >>> room[1:6, 1:6] = 0
    >>> room[2:5, 2:5] = 254
    >>> q = slamq.evaluate(slamq.OccupancyMap(room, room == 205))
    >>> q.enclosed_areas, q.occupied, q.free
    (1, 16, 9)
    """

    source: str
    height: int
    width: int
    total: int
    known: int
    unknown: int
    occupied: int
    free: int
    occupied_fraction: float
    proportion: float
    threshold: float
    corners: int
    enclosed_areas: int
    enclosed_unknown_value: int
    resolution: float | None = None
    known_area_m2: float = math.nan
    corners_canonical: int | None = None
    wall_angle: float = math.nan
    wall_symmetry: str = ""
    saver: str = ""
    flags: str = ""
    known_box_m2: float = math.nan
    curve: tuple[int, ...] | None = None
    params: Params = field(default_factory=Params)
    extra: dict[str, Any] = field(default_factory=dict, compare=False, repr=False)

    @classmethod
    def from_counts(
        cls,
        *,
        source: str,
        shape: tuple[int, int],
        known: int,
        occupied: int,
        sum_darkness: int,
        corners: int,
        curve: Sequence[int],
        params: Params,
        keep_curve: bool,
        resolution: float | None = None,
        corners_canonical: int | None = None,
        wall_angle: float = math.nan,
        wall_harmonics: Sequence[int] | None = None,
        facts: dict[str, Any] | None = None,
    ) -> MapQuality:
        """Build the result from the integers both implementations produce.

        ``curve`` holds ``count_u`` for every ``u`` in ``params.sweep_values``;
        ``wall_angle`` is in radians (the field holds degrees, modulo the period of the
        class :func:`wall_symmetry` gives ``wall_harmonics``).
        """
        height, width = int(shape[0]), int(shape[1])
        total = height * width
        known = int(known)
        occupied = int(occupied)
        unknown = total - known
        free = known - occupied
        nan = math.nan
        occupied_fraction = occupied / known if known else nan
        denominator = free + unknown
        proportion = (occupied / denominator if denominator else nan) if known else nan
        threshold = int(sum_darkness) / (255 * known) if known else nan
        counts = tuple(map(int, curve))
        best = max(counts) if counts else 0
        best_u = params.sweep_values[counts.index(best)] if counts else 0
        symmetry, angle = wall_symmetry(wall_harmonics, float(wall_angle))
        return cls(
            source=source,
            height=height,
            width=width,
            total=total,
            known=known,
            unknown=unknown,
            occupied=occupied,
            free=free,
            occupied_fraction=occupied_fraction,
            proportion=proportion,
            threshold=threshold,
            corners=int(corners),
            enclosed_areas=best,
            enclosed_unknown_value=int(best_u),
            resolution=None if resolution is None else float(resolution),
            known_area_m2=nan if resolution is None else known * float(resolution) ** 2,
            corners_canonical=None if corners_canonical is None else int(corners_canonical),
            wall_angle=angle,
            wall_symmetry=symmetry,
            **(facts or {}),
            curve=counts if keep_curve else None,
            params=params,
        )

    def to_dict(self) -> dict[str, Any]:
        """A flat, JSON-ready dict: every field, the curve as a list, params inlined.

        Examples
        --------
        >>> import numpy as np, slamq
        >>> d = slamq.evaluate(np.full((3, 3), 254, np.uint8)).to_dict()
        >>> d["corners"], d["param_sweep_step"]
        (0, 1)
        """
        # every field but params holds an immutable value: a shallow copy is asdict's
        # result without its per-element recursion into the 256-value curve
        out = {name: getattr(self, name) for name in _FIELDS}
        if out["curve"] is not None:
            out["curve"] = list(out["curve"])
        out.update(self.extra)
        out.update({f"param_{k}": v for k, v in self.params.to_dict().items()})
        return out

    def value(self, name: str) -> Any:
        """The value of column ``name``: a field, or a registered column's (None when this
        result lacks it).

        Examples
        --------
        >>> import numpy as np, slamq
        >>> slamq.evaluate(np.zeros((2, 3), np.uint8)).value("width")
        3
        """
        if name in _FIELD_SET:
            return getattr(self, name)
        return self.extra.get(name)

    def differences(self, other: MapQuality, rel: float = 1e-12) -> list[str]:
        """Fields on which two results disagree (integers exactly, ratios to ``rel``).

        Examples
        --------
        >>> import numpy as np, slamq
        >>> q = slamq.evaluate(np.zeros((4, 4), np.uint8))
        >>> q.differences(q)
        []
        """
        diffs = []
        for name in _compared():
            a, b = self.value(name), other.value(name)
            if _close(a, b, rel) or (name == "curve" and (a is None or b is None)):
                continue
            diffs.append(f"{name}: {a!r} != {b!r}")
        return diffs


#: The fields of a result that are record columns, in order (all but ``params``, ``extra``).
_FIELDS = tuple(f.name for f in fields(MapQuality) if f.name not in ("params", "extra"))
_FIELD_SET = frozenset(_FIELDS)
#: Not compared by :meth:`MapQuality.differences`: the map's name, and the figures derived
#: from the map's size and resolution alone (as the loader gave them to both sides).
_NOT_COMPARED = frozenset({"source", "resolution", "known_area_m2"})


def _compared() -> tuple[str, ...]:
    """The map columns both implementations compute: every one but :data:`_NOT_COMPARED`
    (registered ones included)."""
    return tuple(n for n in group_names("map") if n not in _NOT_COMPARED)


def _close(a: Any, b: Any, rel: float) -> bool:
    """Equal: integers, text and lists exactly, floats to ``rel`` (NaN equals NaN)."""
    if isinstance(a, float) and isinstance(b, float):
        if math.isnan(a) or math.isnan(b):
            return math.isnan(a) and math.isnan(b)
        return math.isclose(a, b, rel_tol=rel, abs_tol=0.0)
    return bool(a == b)
