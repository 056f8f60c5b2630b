"""The definition of slamq's numbers: docs/spec.md sections 2-4 with plain OpenCV/numpy calls.

This module is deliberately slow and literal. Each step of the SPEC is one numpy or OpenCV
call, and the enclosed-area sweep recomputes everything (fill, Otsu, labelling) for every
unknown value ``u``. The Rust core (:func:`slamq.evaluate`) must return the same integers;
``slamq.evaluate(..., verify=True)`` and ``tests/test_conformance.py`` check that.

Exactness
---------
Every intermediate that is compared with a threshold is an integer held exactly in a
float64 or int64 array: the 5x5 binomial blur is ``256 x GaussianBlur`` (at most
``255 * 256``), the Laplacian, Sobel derivatives and 2x2 box sums are small integers.
The only float formulas are the Harris response ``(A*C - B*B) - k*(A+C)**2`` (int64
products, then one float64 multiply and one subtraction), the two relative thresholds,
and Otsu's loop, which is OpenCV's ``getThreshVal_Otsu_8u``.

Otsu and Intel IPP
------------------
opencv-python wheels built with Intel IPP answer ``THRESH_OTSU`` with IPP's
``ippiComputeThreshold_Otsu_8u_C1R`` instead of the C++ loop SPEC section 4 describes.
:func:`otsu_threshold` therefore calls ``cv2.threshold`` with IPP switched off (and
restored afterwards), so that OpenCV runs exactly the loop transcribed in
:func:`otsu_threshold_spec`; the tests compare the two on many images.

Examples
--------
>>> import numpy as np
>>> from slamq import OccupancyMap, reference
>>> room = np.full((7, 7), 205, np.uint8)
>>> room[1:6, 1:6] = 0
>>> room[2:5, 2:5] = 254
>>> q = reference.evaluate(OccupancyMap(room, room == 205))
>>> q.enclosed_areas, q.occupied, q.free
(1, 16, 9)
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator
from typing import Any, NamedTuple

import cv2
import numpy as np

from slamq.errors import ParamError
from slamq.models import MapQuality, OccupancyMap
from slamq.models.quality import map_facts
from slamq.params import Params, params_doc

__all__ = [
    "OccupancyCounts",
    "canonical_corner_count",
    "canonical_map",
    "corner_count",
    "corner_mask",
    "corner_points",
    "enclosed_count",
    "enclosed_curve",
    "enclosed_labels",
    "evaluate",
    "filled_image",
    "gaussian",
    "harris_response",
    "ipp_disabled",
    "known_bounds",
    "laplacian",
    "log_response",
    "occupancy_counts",
    "otsu_histogram",
    "otsu_threshold",
    "otsu_threshold_spec",
    "structure_image",
    "structure_mask",
    "wall_angle",
    "wall_harmonics",
]

#: OpenCV's 5-tap Gaussian kernel for ksize 5, sigma 0 (``getGaussianKernel(5, 0) * 16``).
BINOMIAL = np.array([1.0, 4.0, 6.0, 4.0, 1.0])
#: ``FLT_EPSILON`` from <cfloat>, as a float64 (OpenCV's Otsu loop compares doubles with it).
FLT_EPSILON = float(np.finfo(np.float32).eps)

_BORDER = cv2.BORDER_REFLECT_101


class OccupancyCounts(NamedTuple):
    """The integers of SPEC section 2 from which every proportion ratio is computed.

    Attributes
    ----------
    known : int
        Number of known cells ``n``.
    occupied : int
        Known cells with ``d * n > sum_darkness`` (``d = 255 - v``).
    sum_darkness : int
        ``sum(255 - v)`` over the known cells.
    """

    known: int
    occupied: int
    sum_darkness: int


def _params(params: Params | None) -> Params:
    return Params() if params is None else params


# ---------------------------------------------------------------------------------------
# SPEC section 2: occupied proportion
# ---------------------------------------------------------------------------------------


def occupancy_counts(grid: OccupancyMap) -> OccupancyCounts:
    """Known, occupied and summed darkness of a map, in exact integers (SPEC section 2).

    A known cell with darkness ``d = 255 - v`` is occupied iff ``d * n > sum d``, with
    ``n`` the number of known cells (ties are free).

    Parameters
    ----------
    grid : OccupancyMap

    Returns
    -------
    OccupancyCounts

    Examples
    --------
    >>> import numpy as np
    >>> from slamq import OccupancyMap
    >>> v = np.array([[0, 254, 254, 100]], np.uint8)
    >>> occupancy_counts(OccupancyMap(v, np.array([[False, False, False, True]])))
    OccupancyCounts(known=3, occupied=1, sum_darkness=257)
    """
    known_mask = ~grid.unknown
    d = 255 - grid.values[known_mask].astype(np.int64)
    n = int(d.size)
    total = int(d.sum())
    occupied = int(np.count_nonzero(d * n > total))
    return OccupancyCounts(known=n, occupied=occupied, sum_darkness=total)


# ---------------------------------------------------------------------------------------
# SPEC section 3: corners
# ---------------------------------------------------------------------------------------


def structure_image(grid: OccupancyMap) -> np.ndarray:
    """Step 1: ``S = v`` for known cells, 0 for unknown cells (float64, integer valued).

    Examples
    --------
    >>> import numpy as np
    >>> from slamq import OccupancyMap
    >>> structure_image(OccupancyMap(np.array([[7, 9]], np.uint8), np.array([[False, True]])))
    array([[7., 0.]])
    """
    return np.where(grid.unknown, 0, grid.values).astype(np.float64)


def gaussian(image: np.ndarray) -> np.ndarray:
    """Step 2: the 5x5 binomial sum ``G = sum b_i b_j S`` (``256 x GaussianBlur``), reflect-101.

    Examples
    --------
    >>> import numpy as np
    >>> float(gaussian(np.full((3, 3), 2.0))[1, 1])
    512.0
    """
    return cv2.filter2D(
        np.asarray(image, np.float64), cv2.CV_64F, np.outer(BINOMIAL, BINOMIAL),
        borderType=_BORDER,
    )


def laplacian(image: np.ndarray) -> np.ndarray:
    """Step 3: ``up + down + left + right - 4 x centre`` (``Laplacian`` ksize 1), reflect-101.

    Examples
    --------
    >>> import numpy as np
    >>> laplacian(np.array([[0.0, 0, 0], [0, 1, 0], [0, 0, 0]]))[1]  # reflect-101 doubles edges
    array([ 2., -4.,  2.])
    """
    return cv2.Laplacian(np.asarray(image, np.float64), cv2.CV_64F, ksize=1, borderType=_BORDER)


def log_response(grid: OccupancyMap) -> np.ndarray:
    """Steps 1-3: the Laplacian of the binomial blur of the structure image (exact integers).

    Examples
    --------
    >>> import numpy as np
    >>> from slamq import OccupancyMap
    >>> img = np.full((9, 9), 254, np.uint8)
    >>> img[:, 4] = 0                               # a dark vertical line
    >>> L = log_response(OccupancyMap(img, np.zeros_like(img, bool)))
    >>> bool(L[4, 4] > 0.1 * 255 * 256), bool(L[4, 0] == 0)
    (True, True)
    """
    return laplacian(gaussian(structure_image(grid)))


def _drop_small_components(mask: np.ndarray, min_area: int) -> np.ndarray:
    """8-connected components of ``mask`` with at least ``min_area`` cells."""
    n, labels, stats, _ = cv2.connectedComponentsWithStats(
        mask.astype(np.uint8), connectivity=8, ltype=cv2.CV_32S
    )
    keep = stats[:, cv2.CC_STAT_AREA] >= min_area
    keep[0] = False  # background
    return keep[labels]


def structure_mask(grid: OccupancyMap, params: Params | None = None) -> np.ndarray:
    """Steps 4-5: ``L > log_threshold * 255 * 256``, less components under ``min_dot_area``.

    Parameters
    ----------
    grid : OccupancyMap
    params : Params, optional
        Uses ``log_threshold`` and ``min_dot_area`` (defaults when omitted).

    Returns
    -------
    numpy.ndarray
        ``(H, W)`` bool: the mask ``M`` that the Harris step works on.

    Examples
    --------
    >>> import numpy as np
    >>> from slamq import OccupancyMap
    >>> img = np.full((12, 12), 254, np.uint8)
    >>> img[2:10, 5] = 0                            # a wall, 8 cells long
    >>> img[1, 1] = 0                               # a speck
    >>> m = structure_mask(OccupancyMap(img, np.zeros_like(img, bool)))
    >>> bool(m[5, 5]), bool(m[1, 1])
    (True, False)
    """
    p = _params(params)
    raw = log_response(grid) > p.log_threshold * 255 * 256
    return _drop_small_components(raw, p.min_dot_area)


def harris_response(grid: OccupancyMap, params: Params | None = None) -> np.ndarray:
    """Step 6: ``R = (A*C - B*B) - k*(A+C)**2`` on the structure mask (float64).

    ``Ix, Iy`` are 3x3 Sobel derivatives of the 0/1 mask; ``A, B, C`` the sums of
    ``Ix*Ix, Ix*Iy, Iy*Iy`` over the 2x2 window whose bottom-right cell is the cell
    (OpenCV ``boxFilter`` with a 2x2 block and the default anchor), all reflect-101.

    Examples
    --------
    >>> import numpy as np
    >>> from slamq import OccupancyMap
    >>> img = np.full((20, 20), 254, np.uint8)
    >>> img[5:15, 5:15] = 0
    >>> R = harris_response(OccupancyMap(img, np.zeros_like(img, bool)))
    >>> R.shape, bool(R.max() > 0)
    ((20, 20), True)
    """
    p = _params(params)
    m = structure_mask(grid, p).astype(np.float64)
    ix = cv2.Sobel(m, cv2.CV_64F, 1, 0, ksize=3, borderType=_BORDER)
    iy = cv2.Sobel(m, cv2.CV_64F, 0, 1, ksize=3, borderType=_BORDER)

    def box(x: np.ndarray) -> np.ndarray:
        s = cv2.boxFilter(x, cv2.CV_64F, (2, 2), normalize=False, borderType=_BORDER)
        return s.astype(np.int64)

    a, b, c = box(ix * ix), box(ix * iy), box(iy * iy)
    return (a * c - b * b) - p.harris_k * (a + c) ** 2


def corner_mask(grid: OccupancyMap, params: Params | None = None) -> np.ndarray:
    """Step 7: ``R > harris_quality * max R``; all False when ``max R <= 0``.

    Returns
    -------
    numpy.ndarray
        ``(H, W)`` bool.

    Examples
    --------
    >>> import numpy as np
    >>> from slamq import OccupancyMap
    >>> flat = np.full((4, 4), 254, np.uint8)
    >>> bool(corner_mask(OccupancyMap(flat, np.zeros((4, 4), bool))).any())
    False
    """
    p = _params(params)
    r = harris_response(grid, p)
    max_r = float(r.max())
    if not max_r > 0.0:
        return np.zeros(r.shape, bool)
    return r > p.harris_quality * max_r


def corner_points(grid: OccupancyMap, params: Params | None = None) -> np.ndarray:
    """Centroids ``(row, col)`` of the 8-connected corner-mask components, one per corner.

    Returns
    -------
    numpy.ndarray
        ``(K, 2)`` float64, in OpenCV's label order (raster order of each component's
        first cell).

    Examples
    --------
    >>> import numpy as np
    >>> from slamq import OccupancyMap
    >>> img = np.full((20, 20), 254, np.uint8)
    >>> img[8:12, 8:12] = 0                         # a 4x4 obstacle
    >>> corner_points(OccupancyMap(img, np.zeros_like(img, bool)))
    array([[ 8.5,  8.5],
           [ 8.5, 11.5],
           [11.5,  8.5],
           [11.5, 11.5]])
    """
    mask = corner_mask(grid, params)
    n, _, _, centroids = cv2.connectedComponentsWithStats(
        mask.astype(np.uint8), connectivity=8, ltype=cv2.CV_32S
    )
    # OpenCV centroids are (x, y) = (col, row); label 0 is the background.
    return np.ascontiguousarray(centroids[1:n, ::-1], dtype=np.float64).reshape(-1, 2)


def corner_count(grid: OccupancyMap, params: Params | None = None) -> int:
    """Step 8: number of 8-connected components of the corner mask.

    Examples
    --------
    >>> import numpy as np
    >>> from slamq import OccupancyMap
    >>> img = np.full((20, 20), 254, np.uint8)
    >>> img[8:12, 8:12] = 0                         # a 4x4 obstacle: its 4 corners
    >>> corner_count(OccupancyMap(img, np.zeros_like(img, bool)))
    4
    >>> img[5:15, 5:15] = 0                         # 10x10: the 2-cell LoG band inside the
    >>> corner_count(OccupancyMap(img, np.zeros_like(img, bool)))  # edge has 4 inner corners too
    8
    """
    n, _ = cv2.connectedComponents(
        corner_mask(grid, params).astype(np.uint8), connectivity=8, ltype=cv2.CV_32S
    )
    return int(n) - 1


# ---------------------------------------------------------------------------------------
# SPEC section 3a: the canonical corner count
# ---------------------------------------------------------------------------------------


def known_bounds(grid: OccupancyMap) -> tuple[int, int, int, int] | None:
    """Rows ``r0:r1`` and columns ``c0:c1`` of the known cells' bounding box, or None.

    Examples
    --------
    >>> import numpy as np
    >>> from slamq import OccupancyMap
    >>> unknown = np.ones((5, 6), bool)
    >>> unknown[1:3, 2:5] = False
    >>> known_bounds(OccupancyMap(np.zeros((5, 6), np.uint8), unknown))
    (1, 3, 2, 5)
    """
    rows = np.flatnonzero((~grid.unknown).any(axis=1))
    if rows.size == 0:
        return None
    cols = np.flatnonzero((~grid.unknown).any(axis=0))
    return int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1


def _crop(grid: OccupancyMap) -> OccupancyMap | None:
    b = known_bounds(grid)
    if b is None:
        return None
    r0, r1, c0, c1 = b
    return OccupancyMap(np.ascontiguousarray(grid.values[r0:r1, c0:c1]),
                        np.ascontiguousarray(grid.unknown[r0:r1, c0:c1]),
                        resolution=grid.resolution, source=grid.source)


def wall_angle(grid: OccupancyMap) -> float:
    """Dominant wall direction modulo 90 degrees, in radians in (-pi/4, pi/4] (SPEC 3a.2):
    ``atan2(sum im4, sum re4) / 4`` of :func:`wall_harmonics`, 0 when both sums are 0 (a
    map with no known cell or no gradient). The canonical map is turned by it. An
    image-style angle: positive turns +x towards +y (rows down).

    Examples
    --------
    >>> import numpy as np
    >>> from slamq import OccupancyMap
    >>> img = np.full((40, 40), 254, np.uint8)
    >>> img[10, 5:35] = 0
    >>> img[5:35, 20] = 0                          # axis-aligned walls
    >>> abs(wall_angle(OccupancyMap(img, np.zeros_like(img, bool)))) < 1e-9
    True
    """
    re4, im4, *_ = wall_harmonics(grid)
    if re4 == 0 and im4 == 0:
        return 0.0
    return math.atan2(float(im4), float(re4)) / 4.0


def wall_harmonics(grid: OccupancyMap) -> tuple[int, int, int, int, int]:
    """The wall-direction sums of SPEC 3a.2, ``(re4, im4, re6, im6, weight)``.

    On the known cells' bounding box: the structure image's 9x9 binomial sum
    (``[1 8 28 56 70 56 28 8 1]``, two 5x5 blurs in one; reflect-101) taken at every second
    row and column (``D``, integers), the 3x3 Sobel derivatives ``gx, gy`` of ``D``
    (reflect-101), and per cell with ``g = gx + i gy != 0`` the terms ``g**4 / |g|**3``
    (weight ``|g|``, angle ``4 phi``), ``g**6 / |g|**5`` (angle ``6 phi``) and ``|g|``,
    each rounded half to even to an integer and summed exactly. All 0 for a map with no
    known cell. :func:`slamq.models.quality.wall_symmetry` classifies the map from them.

    Examples
    --------
    >>> import numpy as np
    >>> from slamq import OccupancyMap
    >>> img = np.full((40, 40), 254, np.uint8)
    >>> img[10, 5:35] = 0
    >>> img[5:35, 20] = 0
    >>> re4, im4, re6, im6, weight = wall_harmonics(OccupancyMap(img, img < 0))
    >>> re4 > 0.5 * weight, im4
    (True, 0)
    """
    crop = _crop(grid)
    if crop is None:
        return (0, 0, 0, 0, 0)
    b9 = np.array([1.0, 8.0, 28.0, 56.0, 70.0, 56.0, 28.0, 8.0, 1.0])
    g2 = cv2.sepFilter2D(structure_image(crop), cv2.CV_64F, b9, b9, borderType=_BORDER)
    g2 = np.ascontiguousarray(g2[::2, ::2])
    x = cv2.Sobel(g2, cv2.CV_64F, 1, 0, ksize=3, borderType=_BORDER)
    y = cv2.Sobel(g2, cv2.CV_64F, 0, 1, ksize=3, borderType=_BORDER)
    r2 = x * x + y * y
    keep = r2 > 0
    x, y, r2 = x[keep], y[keep], r2[keep]
    a = x * x - y * y
    b = 2.0 * (x * y)
    root = np.sqrt(r2)
    w = r2 * root
    v = w * r2
    p = a * a - b * b
    q = 2.0 * (a * b)
    sums = (p / w, q / w, (p * a - q * b) / v, (p * b + q * a) / v, root)
    re4, im4, re6, im6, weight = (int(np.rint(t).astype(np.int64).sum()) for t in sums)
    return (re4, im4, re6, im6, weight)


#: Canonical maps larger than this are not built (``corners_canonical`` is None).
MAX_CANONICAL_CELLS = 1 << 30


def canonical_map(grid: OccupancyMap, params: Params | None = None) -> OccupancyMap | None:
    """The map turned to its dominant wall direction and resampled (SPEC 3a.3).

    The known cells' bounding box (``h x w`` cells of resolution ``res``) is turned by
    ``-theta`` (:func:`wall_angle`) about its centre cell ``(h // 2, w // 2)`` and sampled
    on a grid of ``canonical_resolution`` metres (``f = canonical_resolution / res`` input cells per
    output cell; ``f = 1`` when the map has no resolution). The output is ``W x H`` with
    ``W = 2 (ceil((|cos| w + |sin| h) / 2f) + 2)``, ``H`` likewise, centred on the box.
    Each output cell takes ``n x n`` samples (``n = max(2, ceil(f))``) at the centres of
    its ``n x n`` sub-cells, each sample the input cell under it (nearest; beyond the box's
    edge, the edge cell: a fully known map gets no artificial frontier); the cell is the
    mean of the known samples rounded half up, ``(2 sum + k) // 2k``, or unknown when fewer
    than half the samples are known. None when the result would exceed
    ``MAX_CANONICAL_CELLS`` cells, and when ``params.canonical_resolution`` is 0 (the
    default: no canonical map); a map without known cells is returned as it is.

    Examples
    --------
    >>> import numpy as np
    >>> from slamq import OccupancyMap, Params
    >>> img = np.full((30, 30), 254, np.uint8)
    >>> img[8, 4:26] = 0
    >>> m = OccupancyMap(img, np.zeros_like(img, bool), resolution=0.05)
    >>> c = canonical_map(m, Params(canonical_resolution=0.07))
    >>> c.shape, c.resolution          # 30 x 30 cells of 0.05 m: 21.4 of 0.07 m, plus margin
    ((26, 26), 0.07)
    >>> canonical_map(m) is None       # the default skips it
    True
    """
    params = _params(params)
    if not params.canonical_resolution > 0:
        return None
    crop = _crop(grid)
    if crop is None:
        return grid
    h, w = crop.shape
    res = crop.resolution
    f = params.canonical_resolution / res if res is not None else 1.0
    theta = wall_angle(crop)
    c, s = math.cos(theta), math.sin(theta)
    half_w = (abs(c) * w + abs(s) * h) / (2.0 * f)
    half_h = (abs(s) * w + abs(c) * h) / (2.0 * f)
    if not (math.isfinite(half_w) and math.isfinite(half_h)):
        return None
    big_w = 2 * (math.ceil(half_w) + 2)
    big_h = 2 * (math.ceil(half_h) + 2)
    if big_w * big_h > MAX_CANONICAL_CELLS:
        return None
    n = max(2, math.ceil(f))
    jj = (np.arange(big_w, dtype=np.float64) - big_w // 2)[None, :]
    ii = (np.arange(big_h, dtype=np.float64) - big_h // 2)[:, None]
    total = np.zeros((big_h, big_w), np.int64)
    count = np.zeros((big_h, big_w), np.int64)
    values = crop.values.astype(np.int64)
    for k in range(n):
        qy = (ii + (k + 0.5) / n) * f
        for m in range(n):
            qx = (jj + (m + 0.5) / n) * f
            px = (c * qx - s * qy) + float(w // 2)
            py = (s * qx + c * qy) + float(h // 2)
            xi = np.clip(np.floor(px), 0, w - 1).astype(np.int64)
            yi = np.clip(np.floor(py), 0, h - 1).astype(np.int64)
            known = ~crop.unknown[yi, xi]
            total += np.where(known, values[yi, xi], 0)
            count += known
    unknown = 2 * count < n * n
    mean = (2 * total + count) // np.maximum(2 * count, 1)
    out = np.where(unknown, 0, mean).astype(np.uint8)
    new_res = params.canonical_resolution if res is not None else None
    return OccupancyMap(out, unknown, resolution=new_res, source=grid.source)


def canonical_corner_count(grid: OccupancyMap, params: Params | None = None) -> int | None:
    """``corners_canonical``: SPEC-3 corners of :func:`canonical_map` (SPEC 3a.4), or None
    when the canonical map would be too large or ``params.canonical_resolution`` is 0 (the
    default).

    Examples
    --------
    >>> import numpy as np
    >>> from slamq import OccupancyMap, Params
    >>> img = np.full((40, 40), 254, np.uint8)
    >>> img[10:30, 10:30] = 0        # an upright square obstacle: as many as ``corners``
    >>> m = OccupancyMap(img, np.zeros_like(img, bool), resolution=0.05)
    >>> canonical_corner_count(m, Params(canonical_resolution=0.07))
    8
    """
    canonical = canonical_map(grid, params)
    return None if canonical is None else corner_count(canonical, params)


# ---------------------------------------------------------------------------------------
# SPEC section 4: enclosed areas
# ---------------------------------------------------------------------------------------


@contextlib.contextmanager
def ipp_disabled() -> Iterator[None]:
    """Run OpenCV without Intel IPP inside the block, restoring the previous setting.

    Examples
    --------
    >>> import cv2
    >>> before = cv2.ipp.useIPP()
    >>> with ipp_disabled():
    ...     cv2.ipp.useIPP()
    False
    >>> cv2.ipp.useIPP() == before
    True
    """
    previous = bool(cv2.ipp.useIPP())
    cv2.ipp.setUseIPP(False)
    try:
        yield
    finally:
        cv2.ipp.setUseIPP(previous)


def otsu_histogram(image: np.ndarray) -> np.ndarray:
    """The 256-bin integer histogram of a uint8 image (int64).

    Examples
    --------
    >>> import numpy as np
    >>> otsu_histogram(np.array([[0, 0, 255]], np.uint8))[[0, 1, 255]]
    array([2, 0, 1])
    """
    return np.bincount(np.asarray(image, np.uint8).ravel(), minlength=256).astype(np.int64)


def otsu_threshold(image: np.ndarray) -> int:
    """Otsu threshold of a uint8 image: OpenCV's ``THRESH_OTSU`` with its C++ loop (IPP off).

    Parameters
    ----------
    image : numpy.ndarray
        2-D uint8.

    Returns
    -------
    int
        ``T`` in 0..255; cells ``> T`` are the bright class.

    Examples
    --------
    >>> import numpy as np
    >>> otsu_threshold(np.array([[10, 10, 200, 200]], np.uint8))
    10
    >>> otsu_threshold(np.full((3, 3), 77, np.uint8))
    0
    """
    img = np.ascontiguousarray(image, dtype=np.uint8)
    with ipp_disabled():
        t, _ = cv2.threshold(img, 0, 255, cv2.THRESH_BINARY + cv2.THRESH_OTSU)
    return int(t)


def otsu_threshold_spec(hist: Any) -> int:
    """SPEC section 4 step 2 transcribed: OpenCV's ``getThreshVal_Otsu_8u`` loop in Python.

    Parameters
    ----------
    hist : sequence of 256 ints
        Cell counts per grey level (:func:`otsu_histogram`); at least one cell.

    Returns
    -------
    int

    Examples
    --------
    >>> import numpy as np
    >>> otsu_threshold_spec(otsu_histogram(np.array([[10, 10, 200, 200]], np.uint8)))
    10
    """
    h = [int(x) for x in hist]
    if len(h) != 256:
        raise ValueError(f"expected a 256-bin histogram, got {len(h)} bins")
    scale = 1.0 / sum(h)
    mu = 0.0
    for i in range(256):
        mu += i * float(h[i])
    mu *= scale
    mu1 = 0.0
    q1 = 0.0
    max_sigma = 0.0
    max_val = 0
    for i in range(256):
        p_i = h[i] * scale
        mu1 *= q1
        q1 += p_i
        q2 = 1.0 - q1
        if min(q1, q2) < FLT_EPSILON or max(q1, q2) > 1.0 - FLT_EPSILON:
            continue
        mu1 = (mu1 + i * p_i) / q1
        mu2 = (mu - q1 * mu1) / q2
        sigma = q1 * q2 * (mu1 - mu2) * (mu1 - mu2)
        if sigma > max_sigma:
            max_sigma = sigma
            max_val = i
    return max_val


def filled_image(grid: OccupancyMap, u: int) -> np.ndarray:
    """Step 1: ``E_u`` = the values with every unknown cell set to ``u`` (uint8).

    Examples
    --------
    >>> import numpy as np
    >>> from slamq import OccupancyMap
    >>> filled_image(OccupancyMap(np.array([[7, 9]], np.uint8), np.array([[False, True]])), 3)
    array([[7, 3]], dtype=uint8)
    """
    u = int(u)
    if not 0 <= u <= 255:
        raise ValueError(f"unknown value u must be in 0..255, got {u}")
    return np.where(grid.unknown, np.uint8(u), grid.values).astype(np.uint8, copy=False)


def _enclosed_components(
    grid: OccupancyMap, u: int, params: Params | None
) -> tuple[np.ndarray, np.ndarray]:
    """Labels of Free at ``u`` and the boolean 'counted' flag per label (0 = background)."""
    p = _params(params)
    e = filled_image(grid, u)
    with ipp_disabled():  # cv2 binarises: free = 1 where E_u > T_u (Otsu), else 0
        _, free = cv2.threshold(e, 0, 1, cv2.THRESH_BINARY + cv2.THRESH_OTSU)
    n, labels, stats, _ = cv2.connectedComponentsWithStats(free, connectivity=8, ltype=cv2.CV_32S)
    height, width = free.shape
    left = stats[:, cv2.CC_STAT_LEFT]
    top = stats[:, cv2.CC_STAT_TOP]
    right = left + stats[:, cv2.CC_STAT_WIDTH]
    bottom = top + stats[:, cv2.CC_STAT_HEIGHT]
    touches = (left == 0) | (top == 0) | (right == width) | (bottom == height)
    counted = ~touches & (stats[:, cv2.CC_STAT_AREA] >= p.min_area)
    counted[0] = False
    return labels, counted


def enclosed_count(grid: OccupancyMap, u: int, params: Params | None = None) -> int:
    """Steps 1-4 at one unknown value: ``count_u``.

    Free = ``E_u > Otsu(E_u)``; counted are its 8-connected components that touch no
    image border cell and have at least ``min_area`` cells.

    Examples
    --------
    >>> import numpy as np
    >>> from slamq import OccupancyMap
    >>> room = np.full((7, 7), 205, np.uint8)
    >>> room[1:6, 1:6] = 0
    >>> room[2:5, 2:5] = 254
    >>> grid = OccupancyMap(room, room == 205)
    >>> enclosed_count(grid, 0), enclosed_count(grid, 255)     # the walls enclose it
    (1, 1)
    >>> room[3, 5] = 254                                        # a door to the outside
    >>> enclosed_count(OccupancyMap(room, room == 205), 0)      # outside dark: still closed
    1
    >>> enclosed_count(OccupancyMap(room, room == 205), 255)    # outside bright: leaks
    0
    """
    _, counted = _enclosed_components(grid, u, params)
    return int(np.count_nonzero(counted))


def enclosed_labels(grid: OccupancyMap, u: int, params: Params | None = None) -> np.ndarray:
    """The counted enclosed regions at unknown value ``u`` as labels.

    Returns
    -------
    numpy.ndarray
        ``(H, W)`` int32: 0 = not a counted region, ``1..count_u`` = the counted regions
        (numbered in OpenCV's label order).

    Examples
    --------
    >>> import numpy as np
    >>> from slamq import OccupancyMap
    >>> room = np.full((7, 7), 205, np.uint8)
    >>> room[1:6, 1:6] = 0
    >>> room[2:5, 2:5] = 254
    >>> enclosed_labels(OccupancyMap(room, room == 205), 0)[3]
    array([0, 0, 1, 1, 1, 0, 0], dtype=int32)
    """
    labels, counted = _enclosed_components(grid, u, params)
    relabel = np.zeros(counted.size, np.int32)
    relabel[counted] = np.arange(1, int(np.count_nonzero(counted)) + 1, dtype=np.int32)
    return relabel[labels]


def enclosed_curve(grid: OccupancyMap, params: Params | None = None) -> list[int]:
    """``count_u`` for every ``u`` in ``params.sweep_values``: one full computation each.

    Examples
    --------
    >>> import numpy as np
    >>> from slamq import OccupancyMap, Params
    >>> room = np.full((7, 7), 205, np.uint8)
    >>> room[1:6, 1:6] = 0
    >>> room[2:5, 2:5] = 254
    >>> room[3, 5] = 254                    # a door: closed only while Otsu puts u with the walls
    >>> enclosed_curve(OccupancyMap(room, room == 205), Params(sweep_step=64))
    [1, 1, 0, 0]
    """
    p = _params(params)
    return [enclosed_count(grid, u, p) for u in p.sweep_values]


# ---------------------------------------------------------------------------------------
# All three
# ---------------------------------------------------------------------------------------


def evaluate(
    grid: OccupancyMap,
    *,
    params: Params | None = None,
    curve: bool = False,
    **metric_params: Any,
) -> MapQuality:
    """The three map metrics by the literal definition (docs/spec.md sections 2-4).

    Same signature and result as :func:`slamq.metrics.evaluate.evaluate` (without
    ``verify`` and ``threads``); slow: the map is labelled once per sweep value.

    Parameters
    ----------
    grid : OccupancyMap
        The map (:func:`slamq.load_map` reads one from a file or an image array).
    params : Params, optional
        All metric parameters at once; or give them one by one as keywords (below).
    curve : bool, default False
        Keep the whole curve ``count_u`` in the result.
    {params}

    Returns
    -------
    MapQuality

    Examples
    --------
    >>> import numpy as np
    >>> from slamq import OccupancyMap
    >>> from slamq.metrics import reference
    >>> img = np.full((20, 20), 254, np.uint8)
    >>> img[8:12, 8:12] = 0          # a square obstacle in open space
    >>> q = reference.evaluate(OccupancyMap(img, np.zeros_like(img, bool)))
    >>> q.occupied, q.corners, q.enclosed_areas
    (16, 4, 0)
    """
    if not isinstance(grid, OccupancyMap):
        raise ParamError(f"reference.evaluate takes an OccupancyMap, not "
                         f"{type(grid).__name__}; read files and arrays with slamq.load_map")
    params = Params.resolve(params, metric_params)
    counts = occupancy_counts(grid)
    return MapQuality.from_counts(
        source=grid.source,
        shape=grid.shape,
        known=counts.known,
        occupied=counts.occupied,
        sum_darkness=counts.sum_darkness,
        corners=corner_count(grid, params),
        curve=enclosed_curve(grid, params),
        params=params,
        keep_curve=curve,
        resolution=grid.resolution,
        corners_canonical=canonical_corner_count(grid, params),
        # always: the verdict needs every map's orientation and symmetry
        wall_angle=wall_angle(grid),
        wall_harmonics=wall_harmonics(grid),
        facts=map_facts(grid),
    )


evaluate.__doc__ = params_doc(evaluate.__doc__)
