"""A map compared with its ground truth, drawn for people (docs/spec.md section 7): the
aligned estimate over the ground truth's grid, walls coloured by what the comparison found.

Only numpy and OpenCV (slamq's own dependencies): ``slamq compare --overlay`` works without
the ``report`` extra.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from slamq.errors import SlamqError
from slamq.models import MapComparison, OccupancyMap

__all__ = ["COMPARISON_COLOURS", "comparison_image", "ground_truth_layer",
           "ground_truth_layer_colours", "ground_truth_layer_index", "write_comparison_png"]

#: RGB of each kind of cell, painted in this order (later ones on top).
COMPARISON_COLOURS: dict[str, tuple[int, int, int]] = {
    "free": (255, 255, 255),       # the ground truth says free
    "unknown": (205, 205, 205),    # the ground truth does not know
    "matched": (0, 150, 0),        # a wall both maps have (within the tolerance)
    "missing": (220, 0, 0),        # a ground-truth wall the estimate lacks
    "ghost": (30, 80, 230),        # an estimate wall the ground truth lacks
}

#: The kinds of comparison_image, in painting order.
_PAINTED = ("unknown", "free", "matched", "missing", "ghost")
#: The kinds of ground_truth_layer, after the transparent 0, in painting order.
_LAYERED = ("ghost", "matched", "missing")

# bits of MapComparison.cells (rust/src/compare/flag.rs)
_E, _G, _E_OK, _G_OK, _FREE = 1, 2, 4, 8, 32


def comparison_image(comparison: MapComparison, scale: int | None = None) -> np.ndarray:
    """RGB image of a comparison made with ``cells=True``: the ground truth's grid, north
    up, matched walls green, missing walls red, ghost walls blue.

    Parameters
    ----------
    comparison : MapComparison
        From ``slamq.compare(..., cells=True)``.
    scale : int, optional
        Pixels per cell (default: enough for about 800 pixels on the longer side, at most 8).

    Returns
    -------
    numpy.ndarray
        ``(H*scale, W*scale, 3)`` uint8.

    Examples
    --------
    >>> import numpy as np, slamq
    >>> gt = np.full((20, 20), 254, np.uint8); gt[5, 2:18] = 0; gt[2:18, 10] = 0
    >>> est = gt.copy(); est[2:18, 10] = 254; est[15, 2:18] = 0   # one missing, one ghost
    >>> img = comparison_image(slamq.compare(est, gt, align="origin", cells=True), scale=1)
    >>> img[5, 3].tolist(), img[12, 10].tolist(), img[15, 3].tolist()
    ([0, 150, 0], [220, 0, 0], [30, 80, 230])
    """
    cells = comparison.cells
    if cells is None:
        raise SlamqError("the comparison has no cells: call slamq.compare(..., cells=True)")
    h, w = cells.shape
    if scale is None:
        scale = max(1, min(8, 800 // max(h, w)))
    # each cell's kind (an index into _PAINTED), painted in order, then coloured once
    kind = np.zeros((h, w), np.uint8)  # unknown
    kind[(cells & _FREE) != 0] = 1
    kind[((cells & _G_OK) != 0) | ((cells & _E_OK) != 0)] = 2
    kind[((cells & _G) != 0) & ((cells & _G_OK) == 0)] = 3
    kind[((cells & _E) != 0) & ((cells & _E_OK) == 0)] = 4
    if scale > 1:
        kind = np.repeat(np.repeat(kind, scale, axis=0), scale, axis=1)
    img = np.asarray([COMPARISON_COLOURS[k] for k in _PAINTED], np.uint8)[kind]
    return img


def write_comparison_png(path: str | os.PathLike[str], comparison: MapComparison,
                         scale: int | None = None) -> Path:
    """Write :func:`comparison_image` as a PNG; returns the path.

    Examples
    --------
    >>> import pathlib, tempfile, numpy as np, slamq
    >>> gt = np.full((10, 10), 254, np.uint8); gt[3, 1:9] = 0
    >>> c = slamq.compare(gt, gt, cells=True)
    >>> write_comparison_png(pathlib.Path(tempfile.mkdtemp()) / "o.png", c).suffix
    '.png'
    """
    import cv2

    path = Path(path)
    img = comparison_image(comparison, scale)
    if not cv2.imwrite(str(path), np.ascontiguousarray(img[:, :, ::-1])):
        raise SlamqError(f"{path}: cannot write the overlay PNG")
    return path


def ground_truth_layer(
    comparison: MapComparison,
    estimate: OccupancyMap,
    ground_truth: OccupancyMap,
    *,
    offset: tuple[int, int],
    shape: tuple[int, int],
    scale: int,
) -> np.ndarray:
    """The comparison drawn in the *estimate's* picture, as a transparent layer: the
    ground truth's walls moved into the estimate's frame by the inverse of the fitted
    motion (green where the estimate has them, red where it lacks them) and the estimate's
    walls the ground truth lacks (blue), with :data:`COMPARISON_COLOURS`.

    Parameters
    ----------
    comparison : MapComparison
        ``slamq.compare(estimate, ground_truth, cells=True)``.
    estimate, ground_truth : OccupancyMap
        The two maps compared (their frames place the cells).
    offset : tuple of int
        ``(row, col)`` of the estimate cell at the picture's top-left corner.
    shape : tuple of int
        ``(rows, cols)`` of estimate cells the picture shows.
    scale : int
        Pixels per estimate cell.

    Returns
    -------
    numpy.ndarray
        ``(rows*scale, cols*scale, 4)`` uint8 RGBA, transparent where nothing is drawn.

    Examples
    --------
    >>> import numpy as np, slamq
    >>> gt = np.full((20, 20), 254, np.uint8); gt[5, 2:18] = 0
    >>> est = np.full((20, 20), 254, np.uint8)            # the estimate lacks the wall
    >>> e, g = slamq.OccupancyMap(est, est == 205), slamq.OccupancyMap(gt, gt == 205)
    >>> c = slamq.compare(e, g, align="origin", cells=True)
    >>> layer = ground_truth_layer(c, e, g, offset=(0, 0), shape=(20, 20), scale=1)
    >>> layer[5, 3].tolist(), int(layer[6, 3, 3])
    ([220, 0, 0, 255], 0)
    """
    index = ground_truth_layer_index(comparison, estimate, ground_truth, offset=offset,
                                     shape=shape, scale=scale)
    return np.asarray(ground_truth_layer_colours(), np.uint8)[index]


def ground_truth_layer_colours() -> list[tuple[int, int, int, int]]:
    """RGBA of each value of :func:`ground_truth_layer_index` (0: transparent)."""
    return [(0, 0, 0, 0), *(COMPARISON_COLOURS[k] + (255,) for k in _LAYERED)]


def ground_truth_layer_index(
    comparison: MapComparison,
    estimate: OccupancyMap,
    ground_truth: OccupancyMap,
    *,
    offset: tuple[int, int],
    shape: tuple[int, int],
    scale: int,
) -> np.ndarray:
    """:func:`ground_truth_layer` as a ``(rows*scale, cols*scale)`` uint8 array of
    indices into :func:`ground_truth_layer_colours` (0 transparent, 1 ghost, 2 matched,
    3 missing): one byte a pixel, written as a palette PNG.

    Examples
    --------
    >>> import numpy as np, slamq
    >>> gt = np.full((20, 20), 254, np.uint8); gt[5, 2:18] = 0
    >>> est = np.full((20, 20), 254, np.uint8)
    >>> e, g = slamq.OccupancyMap(est, est == 205), slamq.OccupancyMap(gt, gt == 205)
    >>> c = slamq.compare(e, g, align="origin", cells=True)
    >>> idx = ground_truth_layer_index(c, e, g, offset=(0, 0), shape=(20, 20), scale=1)
    >>> int(idx[5, 3]), int(idx[6, 3])
    (3, 0)
    """
    cells = comparison.cells
    if cells is None:
        raise SlamqError("the comparison has no cells: call slamq.compare(..., cells=True)")
    res_g = ground_truth.resolution or estimate.resolution or 1.0
    res_e = estimate.resolution or ground_truth.resolution or 1.0
    hg = cells.shape[0]
    he = estimate.values.shape[0]
    rows, cols = shape
    layer = np.zeros((rows * scale, cols * scale), np.uint8)
    side = max(1, int(round(res_g / res_e * scale)))
    # T (estimate world -> ground-truth world) is p -> R(dyaw) p + (dx, dy); its inverse
    # takes the ground truth's cell centres into the estimate's world
    yaw = np.radians(comparison.dyaw)
    for value, mask in enumerate((
        ((cells & _E) != 0) & ((cells & _E_OK) == 0),      # ghost
        ((cells & _G) != 0) & ((cells & _G_OK) != 0),      # matched
        ((cells & _G) != 0) & ((cells & _G_OK) == 0),      # missing
    ), start=1):
        r, c = np.nonzero(mask)
        if not len(r):
            continue
        # ground-truth cell centres in the ground truth's world
        gx, gy, gyaw = ground_truth.origin
        mx, my = (c + 0.5) * res_g, (hg - r - 0.5) * res_g
        wx = np.cos(gyaw) * mx - np.sin(gyaw) * my + gx
        wy = np.sin(gyaw) * mx + np.cos(gyaw) * my + gy
        # T^-1: into the estimate's world
        px, py = wx - comparison.dx, wy - comparison.dy
        ex = np.cos(yaw) * px + np.sin(yaw) * py
        ey = -np.sin(yaw) * px + np.cos(yaw) * py
        # into the estimate's map frame, then its (fractional) cells, then pixels
        ox, oy, oyaw = estimate.origin
        qx, qy = ex - ox, ey - oy
        lx = np.cos(oyaw) * qx + np.sin(oyaw) * qy
        ly = -np.sin(oyaw) * qx + np.cos(oyaw) * qy
        col = lx / res_e - 0.5
        row = he - ly / res_e - 0.5
        x0 = np.rint((col - offset[1] + 0.5) * scale - side / 2).astype(np.int64)
        y0 = np.rint((row - offset[0] + 0.5) * scale - side / 2).astype(np.int64)
        for dy in range(side):
            for dx in range(side):
                yy, xx = y0 + dy, x0 + dx
                keep = (yy >= 0) & (yy < layer.shape[0]) & (xx >= 0) & (xx < layer.shape[1])
                layer[yy[keep], xx[keep]] = value
    return layer
