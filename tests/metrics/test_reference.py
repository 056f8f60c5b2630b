"""Hand-built maps whose answers are known by construction, for both implementations.

Every expected number below is derived in the comments from SPEC.md, not copied from a
run. Each map-level test runs on :func:`slamq.metrics.reference.evaluate` (the definition) and on
:func:`slamq.evaluate` (the Rust core; skipped until ``slamq._core`` is built).

The second half checks the reference's OpenCV calls against a naive, loop-level
transcription of SPEC sections 3-4 (explicit reflect-101 indices, a breadth-first
8-connected labelling, the Otsu loop), on hand-built and hypothesis maps, so that the
definition itself does not rest on how OpenCV treats tiny images or on Intel IPP.
"""

from __future__ import annotations

import math
from collections import deque
from typing import Any, Callable

import cv2
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from strategies import occupancy_maps

import slamq
from slamq import OccupancyMap, Params
from slamq.metrics import reference

# ---------------------------------------------------------------------------------------
# The two implementations
# ---------------------------------------------------------------------------------------


def _rust_evaluate(source: Any, **kwargs: Any) -> slamq.MapQuality:
    pytest.importorskip("slamq._core", reason="the Rust core is not built (maturin develop)")
    return slamq.evaluate(source, **kwargs)


IMPLEMENTATIONS = [
    pytest.param(reference.evaluate, id="reference"),
    pytest.param(_rust_evaluate, id="rust"),
]
Evaluate = Callable[..., slamq.MapQuality]


def known(values: np.ndarray) -> OccupancyMap:
    """A map with every cell known."""
    values = np.asarray(values, np.uint8)
    return OccupancyMap(values, np.zeros(values.shape, bool))


def shaded(values: np.ndarray) -> OccupancyMap:
    """A map_saver-style map: 205 is unknown."""
    values = np.asarray(values, np.uint8)
    return OccupancyMap(values, values == 205)


def room_map() -> OccupancyMap:
    """16 x 20 unknown canvas; a 1-cell wall ring at rows 3..12, cols 4..15; free inside."""
    v = np.full((16, 20), 205, np.uint8)
    v[3:13, 4:16] = 0  # 10 x 12 block of wall ...
    v[4:12, 5:15] = 254  # ... hollowed to an 8 x 10 free interior
    return shaded(v)


def two_rooms_map() -> OccupancyMap:
    """``room_map`` with an inner wall at col 9: interiors cols 5..8 (32 cells), 10..14 (40)."""
    v = room_map().values.copy()
    v[4:12, 9] = 0
    return shaded(v)


# ---------------------------------------------------------------------------------------
# Whole maps, both implementations
# ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("evaluate", IMPLEMENTATIONS)
def test_all_free_map(evaluate: Evaluate) -> None:
    # 30 x 40 cells, all known v = 254 (d = 1): d*n = n is not > sum d = n, so nothing is
    # occupied; mean p = 1/255. S is constant, so G is constant (reflect-101), L = 0, the
    # mask is empty, R = 0 everywhere and max R <= 0: no corners. E_u = 254 everywhere for
    # every u (no unknown cell): one histogram bin, every Otsu bin skipped, T = 0, Free is
    # everything, one component touching the border: count_u = 0 for all u.
    q = evaluate(known(np.full((30, 40), 254)), curve=True)
    assert (q.height, q.width, q.total, q.known, q.unknown) == (30, 40, 1200, 1200, 0)
    assert (q.occupied, q.free) == (0, 1200)
    assert q.occupied_fraction == 0.0 and q.proportion == 0.0
    assert q.threshold == 1 / 255
    assert q.corners == 0
    assert (q.enclosed_areas, q.enclosed_unknown_value) == (0, 0)
    assert q.curve == (0,) * 256


@pytest.mark.parametrize("evaluate", IMPLEMENTATIONS)
def test_all_white_map_has_zero_threshold(evaluate: Evaluate) -> None:
    # v = 255: d = 0 everywhere, sum d = 0, 0 > 0 is false: no cell occupied, mean p = 0.
    q = evaluate(known(np.full((5, 7), 255)))
    assert (q.occupied, q.free, q.threshold, q.corners, q.enclosed_areas) == (0, 35, 0.0, 0, 0)


@pytest.mark.parametrize("evaluate", IMPLEMENTATIONS)
@pytest.mark.parametrize("underneath", ["shade", "random"])
def test_no_known_cell(evaluate: Evaluate, underneath: str) -> None:
    # SPEC 1: no known cell -> NaN ratios, zero counts. S = 0 everywhere: no corners.
    # E_u = u everywhere: one bin, T = 0; Free is empty (u = 0) or everything (u > 0,
    # touching the border): count_u = 0, so max 0 reached first at u = 0. The values
    # under unknown cells must not matter.
    shape = (25, 31)
    if underneath == "shade":
        values = np.full(shape, 205, np.uint8)
    else:
        values = np.random.default_rng(7).integers(0, 256, shape).astype(np.uint8)
    q = evaluate(OccupancyMap(values, np.ones(shape, bool)), curve=True)
    assert (q.total, q.known, q.unknown, q.occupied, q.free) == (775, 0, 775, 0, 0)
    assert math.isnan(q.occupied_fraction)
    assert math.isnan(q.proportion)
    assert math.isnan(q.threshold)
    assert q.corners == 0
    assert (q.enclosed_areas, q.enclosed_unknown_value) == (0, 0)
    assert q.curve == (0,) * 256


@pytest.mark.parametrize("evaluate", IMPLEMENTATIONS)
def test_one_closed_room(evaluate: Evaluate) -> None:
    # Wall ring of a 10 x 12 block: 2*12 + 2*8 = 40 cells (d = 255); interior 8*10 = 80
    # (d = 1); 320 - 120 = 200 unknown. n = 120, sum d = 40*255 + 80 = 10280:
    # walls 255*120 > 10280 occupied, interior 120 < 10280 free.
    # Enclosed: walls (v = 0) are never above T >= 0. At u = 0 the histogram is {0, 254}:
    # Free = the interior (254 > T, T < 254), which touches no border: count_0 = 1.
    # Free components are only the interior and the outside (which touches the border),
    # so no u gives more than 1.
    q = evaluate(room_map(), curve=True)
    assert (q.total, q.known, q.unknown, q.occupied, q.free) == (320, 120, 200, 40, 80)
    assert q.occupied_fraction == 40 / 120
    assert q.proportion == 40 / (80 + 200)
    assert q.threshold == 10280 / (255 * 120)
    assert (q.enclosed_areas, q.enclosed_unknown_value) == (1, 0)
    assert q.curve[0] == 1 and max(q.curve) == 1


@pytest.mark.parametrize("evaluate", IMPLEMENTATIONS)
def test_two_rooms(evaluate: Evaluate) -> None:
    # The inner wall adds 8 occupied cells: walls 48, interior 72, sum d = 48*255 + 72.
    # At u = 0 the two interiors (cols 5..8 and 10..14, two columns apart, so not
    # 8-connected) are both enclosed: 2. No u can give 3 (only two interiors exist).
    q = evaluate(two_rooms_map(), curve=True)
    assert (q.known, q.occupied, q.free) == (120, 48, 72)
    assert q.threshold == (48 * 255 + 72) / (255 * 120)
    assert (q.enclosed_areas, q.enclosed_unknown_value) == (2, 0)
    assert q.curve[0] == 2


@pytest.mark.parametrize("evaluate", IMPLEMENTATIONS)
def test_min_area_drops_small_rooms(evaluate: Evaluate) -> None:
    # Interiors of 32 and 40 cells: min_area 33 keeps one, 41 keeps none.
    assert evaluate(two_rooms_map(), min_area=32).enclosed_areas == 2
    assert evaluate(two_rooms_map(), min_area=33).enclosed_areas == 1
    assert evaluate(two_rooms_map(), min_area=41).enclosed_areas == 0


@pytest.mark.parametrize("evaluate", IMPLEMENTATIONS)
def test_room_open_to_the_image_border(evaluate: Evaluate) -> None:
    # Walls on three sides (rows 2 and 9, col 9); the free interior rows 3..8 reaches
    # column 0, a border cell. The other free candidate, the unknown outside, touches the
    # border too. Walls are always obstacle, so count_u = 0 for every u.
    v = np.full((12, 12), 205, np.uint8)
    v[2, 0:10] = 0
    v[9, 0:10] = 0
    v[2:10, 9] = 0
    v[3:9, 0:9] = 254
    q = evaluate(shaded(v), curve=True)
    assert (q.occupied, q.free) == (26, 54)
    assert (q.enclosed_areas, q.enclosed_unknown_value) == (0, 0)
    assert q.curve == (0,) * 256


@pytest.mark.parametrize("evaluate", IMPLEMENTATIONS)
def test_room_whose_walls_are_the_image_border(evaluate: Evaluate) -> None:
    # Walls on the border cells themselves: the interior touches no border cell and is
    # enclosed. No unknown cell, so every u gives the same image: count_u = 1 for all u.
    v = np.zeros((8, 10), np.uint8)
    v[1:7, 1:9] = 254
    q = evaluate(known(v), curve=True)
    assert (q.occupied, q.free) == (2 * 10 + 2 * 6, 48)
    assert (q.enclosed_areas, q.enclosed_unknown_value) == (1, 0)
    assert q.curve == (1,) * 256


# The 4x4 obstacle, derived by hand. S = B (1 - chiX(x) chiY(y)) with B = 254 and
# x, y local to the square (0..3). Blur and Laplacian are separable, so with the 1-D
# kernel g = [1 4 6 4 1]:  L = B (D(x) P(y) + P(x) D(y)),  P = g * chi,
# D = g * (-lap chi) (= +1 at the inner boundary cells, -1 just outside).
#   t:  -3  -2  -1   0   1   2   3   4
#   P:   0   1   5  11  15  15  11   5
#   D:  -1  -3  -2   2   4   4   2  -2
# Inside, L/B >= 2*11 + 11*2 = 44 > 6528/254 = 25.7; outside, D <= 0 on the outside
# coordinate and L/B <= -2*11 + 5*2 < 0. So the mask M is exactly the 4x4 block.
# Harris on the block: Ix = dX(x) smY(y) (dX = [1 1 0 0 -1 -1] at x = -1..4,
# sm = [1 3 4 4 3 1]); the 2x2 window (x-1, x) sums give A = dd(x) ss(y),
# B = ds(x) ds(y), C = ss(x) dd(y) with
#   x:  -1   0   1   2   3   4   5
#   dd:  1   2   1   0   1   2   1
#   ss:  1  10  25  32  25  10   1
#   ds:  1   4   3   0  -3  -4  -1
# R(1,1) = 25*25 - 3^4 - 0.04*(25+25)^2 = 544 - 100 = 444 (the max; also at (1,3),
# (3,1), (3,3)); with p = dd*ss, q = ds^2: R(0,1) = 20*25 - 16*9 - 0.04*(2*25 + 10*1)^2
# = 356 - 144 = 212; R(0,0) = 400 - 256 - 0.04*40^2 = 80. Rows/cols -1, 2, 5 give R <= 0:
# x = 2 has dd = ds = 0 (det 0), R(-1,0) = 20 - 16 - 0.04*12^2 = -1.76, R(-1,1) = -11.04.
# So R > 0.01 * 444 exactly on x, y in {0, 1, 3, 4}: four 2x2 blocks, 4 corners,
# centroids at local 0.5 and 3.5.
SQUARE_AT = 8


def square_obstacle() -> OccupancyMap:
    v = np.full((20, 20), 254, np.uint8)
    v[SQUARE_AT : SQUARE_AT + 4, SQUARE_AT : SQUARE_AT + 4] = 0
    return known(v)


@pytest.mark.parametrize("evaluate", IMPLEMENTATIONS)
def test_square_obstacle(evaluate: Evaluate) -> None:
    # 16 cells d = 255, 384 cells d = 1: sum d = 4464, n = 400; 255*400 > 4464 > 400.
    # No unknown: Otsu splits {0} | {254}, Free = the open ground, touching the border.
    q = evaluate(square_obstacle())
    assert (q.occupied, q.free, q.unknown) == (16, 384, 0)
    assert q.threshold == 4464 / (255 * 400)
    assert q.proportion == 16 / 384
    assert q.corners == 4
    assert q.enclosed_areas == 0


def test_square_obstacle_steps() -> None:
    grid = square_obstacle()
    block = np.zeros((20, 20), bool)
    block[SQUARE_AT : SQUARE_AT + 4, SQUARE_AT : SQUARE_AT + 4] = True
    np.testing.assert_array_equal(reference.structure_mask(grid), block)

    r = reference.harris_response(grid)
    o = SQUARE_AT
    assert r.max() == pytest.approx(444.0, rel=1e-15)
    assert r[o + 1, o + 1] == pytest.approx(444.0, rel=1e-15)
    assert r[o + 3, o + 3] == pytest.approx(444.0, rel=1e-15)
    assert r[o, o + 1] == pytest.approx(212.0, rel=1e-15)
    assert r[o, o] == pytest.approx(80.0, rel=1e-15)
    assert r[o - 1, o] == pytest.approx(4 - 0.04 * 144, rel=1e-12)

    expected_mask = np.zeros((20, 20), bool)
    for r0 in (o, o + 3):
        for c0 in (o, o + 3):
            expected_mask[r0 : r0 + 2, c0 : c0 + 2] = True
    np.testing.assert_array_equal(reference.corner_mask(grid), expected_mask)

    points = reference.corner_points(grid)
    expected = [(o + a, o + b) for a in (0.5, 3.5) for b in (0.5, 3.5)]
    np.testing.assert_allclose(points, expected, rtol=0, atol=1e-12)
    assert reference.corner_count(grid) == 4


def test_large_square_has_inner_band_corners() -> None:
    # A 10x10 obstacle: along straight edges only depths t = 0, 1 pass the threshold
    # (1-D: L/B = 16 (g(t) - g(t+1)) = 32, 48, 16 for t = 0, 1, 2 against 25.7), so the
    # mask is a 2-cell band inside the edge and has inner corners as well: 8 corners,
    # 4 of them at the obstacle's corners.
    v = np.full((20, 20), 254, np.uint8)
    v[5:15, 5:15] = 0
    grid = known(v)
    band = reference.structure_mask(grid)
    assert band[10, 5] and band[10, 6] and not band[10, 7]
    points = reference.corner_points(grid)
    assert len(points) == 8
    outer = [(5.5, 5.5), (5.5, 14.5), (14.5, 5.5), (14.5, 14.5)]
    for p in outer:
        assert np.min(np.hypot(*(points - p).T)) < 1e-9


@pytest.mark.parametrize("evaluate", IMPLEMENTATIONS)
@pytest.mark.parametrize("value", [0, 37, 254, 255])
def test_one_by_one_known(evaluate: Evaluate, value: int) -> None:
    # n = 1: d*1 > d is false, so the single cell is free whatever its value (ties are
    # free); mean p = d/255. One cell is a border cell: no enclosed area. A length-1
    # axis reflects onto itself: the Sobel derivatives vanish, no corner.
    q = evaluate(known(np.array([[value]])), curve=True)
    assert (q.total, q.known, q.occupied, q.free) == (1, 1, 0, 1)
    assert q.occupied_fraction == 0.0 and q.proportion == 0.0
    assert q.threshold == (255 - value) / 255
    assert (q.corners, q.enclosed_areas, q.enclosed_unknown_value) == (0, 0, 0)
    assert q.curve == (0,) * 256


@pytest.mark.parametrize("evaluate", IMPLEMENTATIONS)
def test_one_by_one_unknown(evaluate: Evaluate) -> None:
    q = evaluate(OccupancyMap(np.array([[205]], np.uint8), np.array([[True]])))
    assert (q.total, q.known, q.unknown, q.occupied, q.corners, q.enclosed_areas) == (
        1, 0, 1, 0, 0, 0,
    )
    assert math.isnan(q.occupied_fraction) and math.isnan(q.threshold)


@pytest.mark.parametrize("evaluate", IMPLEMENTATIONS)
@pytest.mark.parametrize("transpose", [False, True], ids=["1xN", "Nx1"])
def test_one_by_n(evaluate: Evaluate, transpose: bool) -> None:
    # d = 1 1 255 255 255 1 1, unknown at the end: n = 7, sum d = 769. 255*7 > 769 >= 7:
    # 3 occupied. On a 1-row map every row index reflects to row 0, so the y derivative
    # Iy = M(y+1) - M(y-1) vanishes: B = C = 0 and R = -k A^2 <= 0: no corner. Every cell
    # is a border cell: no enclosed area.
    v = np.array([[254, 254, 0, 0, 0, 254, 254, 205, 205]], np.uint8)
    grid = shaded(v.T if transpose else v)
    q = evaluate(grid, curve=True)
    assert (q.total, q.known, q.unknown, q.occupied, q.free) == (9, 7, 2, 3, 4)
    assert q.proportion == 3 / (4 + 2)
    assert q.threshold == 769 / (255 * 7)
    assert q.corners == 0
    assert q.curve == (0,) * 256


@pytest.mark.parametrize("evaluate", IMPLEMENTATIONS)
@pytest.mark.parametrize("shape", [(2, 2), (2, 9), (9, 2)])
def test_two_wide_maps_have_no_corners(evaluate: Evaluate, shape: tuple[int, int]) -> None:
    # A length-2 axis reflects -1 -> 1 and 2 -> 0, so M(y+1) - M(y-1) = 0 at both rows:
    # again B = C = 0 (or A = B = 0) and R <= 0. Every cell is a border cell.
    rng = np.random.default_rng(3)
    v = rng.choice(np.array([0, 205, 254], np.uint8), shape)
    q = evaluate(shaded(v))
    assert q.corners == 0
    assert q.enclosed_areas == 0


@pytest.mark.parametrize("evaluate", IMPLEMENTATIONS)
def test_sweep_step_and_curve(evaluate: Evaluate) -> None:
    # sweep_step 64 visits u = 0, 64, 128, 192; the room is closed for every u.
    q = evaluate(room_map(), sweep_step=64, curve=True)
    assert q.curve == (1, 1, 1, 1)
    assert evaluate(room_map(), sweep_step=64).curve is None
    assert q.params.sweep_step == 64


@pytest.mark.parametrize("evaluate", IMPLEMENTATIONS)
def test_door_closes_only_while_unknown_is_dark(evaluate: Evaluate) -> None:
    # 7x7: wall ring rows/cols 1..5, 3x3 interior, a door at (3, 5): 15 walls, 10 free,
    # 24 unknown (N = 49). The room is enclosed only when Otsu puts u with the walls.
    # u = 64: split {0,64}|{254}: q1 = 39/49, mu1 = 1536/39, mu2 = 254 gives
    # q1 q2 (mu2-mu1)^2 ~ 7480 against ~3055 for {0}|{64,254}: T = 64, Free = interior +
    # door (bounded by unknown = obstacle): 1. u = 128: {0}|{128,254} wins (~5787 vs
    # ~4986): Free = everything but walls, through the door to the border: 0.
    v = np.full((7, 7), 205, np.uint8)
    v[1:6, 1:6] = 0
    v[2:5, 2:5] = 254
    v[3, 5] = 254
    q = evaluate(shaded(v), sweep_step=64, curve=True)
    assert q.curve == (1, 1, 0, 0)
    assert (q.enclosed_areas, q.enclosed_unknown_value) == (1, 0)


# ---------------------------------------------------------------------------------------
# Step functions of the reference
# ---------------------------------------------------------------------------------------


def test_enclosed_labels_two_rooms() -> None:
    labels = reference.enclosed_labels(two_rooms_map(), 0)
    assert labels.dtype == np.int32
    left = np.zeros((16, 20), bool)
    left[4:12, 5:9] = True
    right = np.zeros((16, 20), bool)
    right[4:12, 10:15] = True
    assert set(np.unique(labels)) == {0, 1, 2}
    assert {tuple(np.unique(labels[left])), tuple(np.unique(labels[right]))} == {(1,), (2,)}
    assert not labels[~(left | right)].any()
    assert reference.enclosed_count(two_rooms_map(), 0) == 2


def test_occupancy_counts_ties_are_free() -> None:
    # d = 0, 255: n = 2, sum = 255; 255*2 > 255 occupied, 0 free.
    assert reference.occupancy_counts(known(np.array([[255, 0]]))) == (2, 1, 255)
    # d = 10, 20, 30: n = 3, sum = 60: 30*3 = 90 > 60 occupied; 20*3 = 60 is a tie: free.
    assert reference.occupancy_counts(known(np.array([[245, 235, 225]]))).occupied == 1


def test_otsu_two_values_and_one_value() -> None:
    # Two values a < b: any T in a..b-1 splits them; the first bin with both classes
    # non-empty is a. One value: q1 jumps 0 -> 1, every bin is skipped: T = 0.
    img = np.array([[10, 10, 10, 200]], np.uint8)
    t = reference.otsu_threshold(img)
    assert 10 <= t < 200
    assert t == reference.otsu_threshold_spec(reference.otsu_histogram(img))
    assert reference.otsu_threshold(np.full((3, 4), 77, np.uint8)) == 0
    assert reference.otsu_threshold_spec(reference.otsu_histogram(np.full((1, 1), 9))) == 0


def test_otsu_tie_is_broken_towards_the_first_bin() -> None:
    # [88, 93, 98]: the splits after 88 and after 93 have the same between-class variance
    # (1/3 * 2/3 * 7.5^2 = 12.5). The OpenCV C++ loop keeps the first (strict >);
    # Intel IPP's ippiComputeThreshold_Otsu (used by cv2 wheels when IPP is on) answers
    # 93. The reference switches IPP off.
    img = np.array([[88, 93, 98]], np.uint8)
    assert reference.otsu_threshold_spec(reference.otsu_histogram(img)) == 88
    assert reference.otsu_threshold(img) == 88


def test_otsu_restores_ipp_setting() -> None:
    before = cv2.ipp.useIPP()
    reference.otsu_threshold(np.array([[1, 2, 3]], np.uint8))
    assert cv2.ipp.useIPP() == before


@settings(max_examples=300, deadline=None)
@given(
    st.integers(1, 40),
    st.integers(1, 40),
    st.lists(st.integers(0, 255), min_size=1, max_size=6),
    st.integers(0, 2**32 - 1),
)
def test_otsu_matches_the_spec_loop(h: int, w: int, palette: list[int], seed: int) -> None:
    rng = np.random.default_rng(seed)
    img = rng.choice(np.array(palette, np.uint8), (h, w))
    assert reference.otsu_threshold(img) == reference.otsu_threshold_spec(
        reference.otsu_histogram(img)
    )


@pytest.mark.parametrize("u", [-1, 256])
def test_filled_image_rejects_bad_u(u: int) -> None:
    with pytest.raises(ValueError, match="0..255"):
        reference.filled_image(room_map(), u)


# ---------------------------------------------------------------------------------------
# The reference against a naive transcription of the SPEC
# ---------------------------------------------------------------------------------------


def _reflect101(i: int, n: int) -> int:
    if n == 1:
        return 0
    period = 2 * (n - 1)
    i %= period
    return i if i < n else period - i


def _shifted(x: np.ndarray, dy: int, dx: int) -> np.ndarray:
    """``out[r, c] = x[reflect(r + dy), reflect(c + dx)]``."""
    h, w = x.shape
    rows = [_reflect101(r + dy, h) for r in range(h)]
    cols = [_reflect101(c + dx, w) for c in range(w)]
    return x[np.ix_(rows, cols)]


def _label8(mask: np.ndarray) -> list[list[tuple[int, int]]]:
    """8-connected components by breadth-first search, as lists of cells."""
    h, w = mask.shape
    seen = np.zeros_like(mask, bool)
    comps = []
    for r0 in range(h):
        for c0 in range(w):
            if not mask[r0, c0] or seen[r0, c0]:
                continue
            seen[r0, c0] = True
            queue, cells = deque([(r0, c0)]), []
            while queue:
                r, c = queue.popleft()
                cells.append((r, c))
                for dr in (-1, 0, 1):
                    for dc in (-1, 0, 1):
                        rr, cc = r + dr, c + dc
                        if 0 <= rr < h and 0 <= cc < w and mask[rr, cc] and not seen[rr, cc]:
                            seen[rr, cc] = True
                            queue.append((rr, cc))
            comps.append(cells)
    return comps


def _naive(grid: OccupancyMap, p: Params) -> dict[str, Any]:
    v = grid.values.astype(np.int64)
    s = np.where(grid.unknown, 0, v)
    b = [1, 4, 6, 4, 1]
    g = sum(b[i] * b[j] * _shifted(s, i - 2, j - 2) for i in range(5) for j in range(5))
    lap = (
        _shifted(g, -1, 0) + _shifted(g, 1, 0) + _shifted(g, 0, -1) + _shifted(g, 0, 1) - 4 * g
    )
    raw = lap > p.log_threshold * 255 * 256
    m = np.zeros(raw.shape, np.int64)
    for cells in _label8(raw):
        if len(cells) >= p.min_dot_area:
            for rc in cells:
                m[rc] = 1
    sm = [1, 2, 1]
    ix = sum(sm[i] * (_shifted(m, i - 1, 1) - _shifted(m, i - 1, -1)) for i in range(3))
    iy = sum(sm[j] * (_shifted(m, 1, j - 1) - _shifted(m, -1, j - 1)) for j in range(3))

    def box(x: np.ndarray) -> np.ndarray:
        return x + _shifted(x, -1, 0) + _shifted(x, 0, -1) + _shifted(x, -1, -1)

    a, bb, c = box(ix * ix), box(ix * iy), box(iy * iy)
    r = (a * c - bb * bb) - p.harris_k * (a + c) ** 2
    max_r = float(r.max())
    corner = r > p.harris_quality * max_r if max_r > 0 else np.zeros(r.shape, bool)
    curve = []
    h, w = v.shape
    for u in p.sweep_values:
        e = np.where(grid.unknown, u, v)
        t = reference.otsu_threshold_spec(np.bincount(e.ravel(), minlength=256))
        count = 0
        for cells in _label8(e > t):
            rows = [rc[0] for rc in cells]
            cols = [rc[1] for rc in cells]
            border = min(rows) == 0 or min(cols) == 0 or max(rows) == h - 1 or max(cols) == w - 1
            if not border and len(cells) >= p.min_area:
                count += 1
        curve.append(count)
    return {"G": g, "L": lap, "M": m.astype(bool), "R": r, "corners": len(_label8(corner)),
            "curve": curve}


@pytest.mark.parametrize(
    "grid",
    [square_obstacle(), room_map(), two_rooms_map(), known(np.array([[3]])),
     shaded(np.array([[0, 254, 205, 0, 0, 0, 254]])), known(np.eye(3, dtype=np.uint8) * 250)],
    ids=["square", "room", "two_rooms", "1x1", "1x7", "3x3"],
)
def test_reference_matches_naive_transcription(grid: OccupancyMap) -> None:
    p = Params(sweep_step=15)
    naive = _naive(grid, p)
    np.testing.assert_array_equal(reference.gaussian(reference.structure_image(grid)), naive["G"])
    np.testing.assert_array_equal(reference.log_response(grid), naive["L"])
    np.testing.assert_array_equal(reference.structure_mask(grid, p), naive["M"])
    np.testing.assert_array_equal(reference.harris_response(grid, p), naive["R"])
    assert reference.corner_count(grid, p) == naive["corners"]
    assert reference.enclosed_curve(grid, p) == naive["curve"]


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    occupancy_maps(max_side=18),
    st.sampled_from([Params(sweep_step=5), Params(min_dot_area=1, sweep_step=9),
                     Params(log_threshold=0.02, harris_quality=0.1, min_area=3, sweep_step=7)]),
)
def test_reference_matches_naive_transcription_on_random_maps(
    grid: OccupancyMap, p: Params
) -> None:
    naive = _naive(grid, p)
    np.testing.assert_array_equal(reference.log_response(grid), naive["L"])
    np.testing.assert_array_equal(reference.structure_mask(grid, p), naive["M"])
    np.testing.assert_array_equal(reference.harris_response(grid, p), naive["R"])
    assert reference.corner_count(grid, p) == naive["corners"]
    assert reference.enclosed_curve(grid, p) == naive["curve"]
