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
from slamq.models import MapComparison

__all__ = ["COMPARISON_COLOURS", "comparison_image", "write_comparison_png"]

#: RGB of each kind of cell, painted in this order (later ones on top).
COMPARISON_COLOURS: dict[str, tuple[int, int, int]] = {
    "free": (255, 255, 255),       # the ground truth says free
    "unknown": (205, 205, 205),    # the ground truth does not know
    "matched": (0, 150, 0),        # a wall both maps have (within the tolerance)
    "missing": (220, 0, 0),        # a ground-truth wall the estimate lacks
    "ghost": (30, 80, 230),        # an estimate wall the ground truth lacks
}

# bits of MapComparison.cells (rust/src/compare.rs, module flag)
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
    img = np.empty((h, w, 3), np.uint8)
    img[:] = COMPARISON_COLOURS["unknown"]
    img[(cells & _FREE) != 0] = COMPARISON_COLOURS["free"]
    img[((cells & _G_OK) != 0) | ((cells & _E_OK) != 0)] = COMPARISON_COLOURS["matched"]
    img[((cells & _G) != 0) & ((cells & _G_OK) == 0)] = COMPARISON_COLOURS["missing"]
    img[((cells & _E) != 0) & ((cells & _E_OK) == 0)] = COMPARISON_COLOURS["ghost"]
    if scale > 1:
        img = np.repeat(np.repeat(img, scale, axis=0), scale, axis=1)
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
