"""``MapComparison``: a map scored against a ground-truth map (SPEC section 7), built from the
counts and sums the Rust core returns."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np

from slamq.columns import group_names

__all__ = ["COMPARISON_FIGURES", "MapComparison"]


@dataclass(frozen=True)
class MapComparison:
    """An estimated map against a ground-truth map, after alignment (docs/spec.md section 7).

    E and G are the occupied cells of the aligned estimate and of the ground truth on the
    ground truth's grid; d(x, S) is the distance in metres from cell x to the nearest cell
    of S.

    Attributes
    ----------
    estimate, ground_truth : str
        Where the two maps came from.
    precision, recall, f1 : float
        Share of E within ``tolerance`` of G; share of G within ``tolerance`` of E; their
        harmonic mean. Higher is better.
    iou : float
        ``|E n G| / |E u G|`` (exact overlap). Higher is better.
    ne : float
        Mean over G of d(g, E), metres (Santos et al.'s normalised error): missing walls.
    reverse : float
        Mean over E of d(e, G), metres: ghost and doubled walls.
    chamfer : float
        ``(ne + reverse) / 2``, metres.
    coverage : float
        Share of the ground truth's free cells that the aligned estimate knows.
    dx, dy, dyaw : float
        The fitted motion applied to the estimate's frame (metres, metres, degrees).
    icp_rms : float
        RMS distance (metres) from the ICP's kept estimate cells to their nearest
        ground-truth cell, at the final alignment (NaN with ``align="origin"``).
    icp_iterations : int
    estimate_occupied, ground_truth_occupied : int
        |E| and |G| in cells of the ground truth's grid.
    truncated : int
        Distances cut at ``max_distance`` (both directions).
    outside : int
        Occupied estimate cells that fall outside the ground truth's grid once aligned
        (left out of every figure).
    tolerance : float
        The matching distance used, metres.
    max_distance : float or None
        The truncation distance used, metres.
    align : str
        The alignment used: ``"origin"``, ``"icp"`` or ``"search"`` (``align="auto"`` says
        which it chose).
    occupied_threshold : float
    resolution : float
        The ground truth's metres per cell (the unit of the comparison grid).
    cells : numpy.ndarray or None
        Per ground-truth cell, bit flags (1 E, 2 G, 4 E matched, 8 G matched, 16 estimate
        known, 32 ground truth free), when asked for (of the cells of ``cells_box`` only,
        when :func:`slamq.compare` was given one). Not part of :meth:`to_dict`.
    note : str
        Empty, or one sentence when the alignment fitted poorly (docs/spec.md section 7,
        "Fit"): which alignment was tried and used, with its precision.

    Examples
    --------
    >>> import numpy as np, slamq
    >>> img = np.full((30, 30), 254, np.uint8)
    >>> img[5, 5:25] = 0
    >>> c = slamq.compare(img, img)
    >>> c.f1, c.iou, c.ne, c.reverse
    (1.0, 1.0, 0.0, 0.0)
    """

    estimate: str
    ground_truth: str
    precision: float
    recall: float
    f1: float
    iou: float
    ne: float
    reverse: float
    chamfer: float
    coverage: float
    dx: float
    dy: float
    dyaw: float
    icp_rms: float
    icp_iterations: int
    estimate_occupied: int
    ground_truth_occupied: int
    truncated: int
    outside: int
    tolerance: float
    max_distance: float | None
    align: str
    occupied_threshold: float
    resolution: float
    cells: np.ndarray | None = field(default=None, compare=False, repr=False)
    note: str = ""

    @classmethod
    def from_counts(
        cls, raw: Any, *, estimate: str, ground_truth: str, resolution: float,
        tolerance: float, max_distance: float | None, align: str,
        occupied_threshold: float, cells: np.ndarray | None = None,
    ) -> MapComparison:
        """The figures from the counts of ``slamq._core.compare`` (distances in cells)."""
        e, g = raw.estimate_occupied, raw.ground_truth_occupied
        precision = _ratio(raw.estimate_matched, e)
        recall = _ratio(raw.ground_truth_matched, g)
        if math.isnan(precision) or math.isnan(recall):
            f1 = math.nan
        elif precision + recall == 0:
            f1 = 0.0
        else:
            f1 = 2 * precision * recall / (precision + recall)
        ne = _ratio(raw.sum_ne, g) * resolution
        reverse = _ratio(raw.sum_reverse, e) * resolution
        return cls(
            estimate=estimate, ground_truth=ground_truth,
            precision=precision, recall=recall, f1=f1,
            iou=_ratio(raw.intersection, raw.union),
            ne=ne, reverse=reverse, chamfer=(ne + reverse) / 2,
            coverage=_ratio(raw.covered, raw.ground_truth_free),
            dx=float(raw.tx), dy=float(raw.ty), dyaw=math.degrees(raw.theta),
            icp_rms=float(raw.icp_rms), icp_iterations=int(raw.icp_iterations),
            estimate_occupied=int(e), ground_truth_occupied=int(g),
            truncated=int(raw.truncated_ne + raw.truncated_reverse),
            outside=int(raw.outside), tolerance=float(tolerance),
            max_distance=None if max_distance is None else float(max_distance),
            align=align, occupied_threshold=float(occupied_threshold),
            resolution=float(resolution), cells=cells,
        )

    def to_dict(self) -> dict[str, Any]:
        """The figures and settings as a plain dict (without ``cells``).

        Examples
        --------
        >>> import numpy as np, slamq
        >>> img = np.full((10, 10), 254, np.uint8); img[2, 2:8] = 0
        >>> d = slamq.compare(img, img).to_dict()
        >>> d["precision"], d["align"], "cells" in d
        (1.0, 'icp', False)
        """
        return {f.name: getattr(self, f.name) for f in fields(self) if f.name != "cells"}


def _ratio(num: float, den: float) -> float:
    return float(num) / float(den) if den else math.nan


#: The figures of a comparison that are ``gt_*`` columns of a batch, in table order
#: (:data:`slamq.columns.COLUMNS`).
COMPARISON_FIGURES: tuple[str, ...] = tuple(
    name[3:] for name in group_names("gt")
    if name[3:] in {f.name for f in fields(MapComparison)})
