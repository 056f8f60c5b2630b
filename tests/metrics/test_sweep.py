"""The fast enclosed-area sweep (one Otsu table, few labellings or one incremental
union-find pass) against the literal one (one OpenCV labelling per unknown value)."""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import slamq
from slamq.metrics import reference
from slamq.params import Params


@st.composite
def graded_with_masks(draw: st.DrawFn) -> slamq.OccupancyMap:
    """Probability-style maps with 100+ grey levels and an independent random unknown mask
    (blobs plus speckle), up to 120 x 120."""
    h = draw(st.integers(2, 120))
    w = draw(st.integers(2, 120))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    levels = draw(st.integers(100, 256))
    base = rng.integers(0, levels, (h, w)) * (255.0 / (levels - 1))
    # smooth it a little so that regions form, then add walls of 0
    k = np.ones((3, 3)) / 9.0
    pad = np.pad(base, 1, mode="edge")
    smooth = sum(pad[i:i + h, j:j + w] * k[i, j] for i in range(3) for j in range(3))
    values = np.clip(np.rint(smooth), 0, 255).astype(np.uint8)
    for _ in range(draw(st.integers(0, 6))):
        r = int(rng.integers(0, h))
        values[r, :] = 0
        c = int(rng.integers(0, w))
        values[:, c] = 0
    unknown = rng.random((h, w)) < draw(st.floats(0.0, 0.6))
    for _ in range(draw(st.integers(0, 4))):
        r0, c0 = int(rng.integers(0, h)), int(rng.integers(0, w))
        unknown[r0:r0 + int(rng.integers(1, h + 1)), c0:c0 + int(rng.integers(1, w + 1))] = True
    return slamq.OccupancyMap(values, unknown)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(grid=graded_with_masks(), min_area=st.sampled_from([1, 1, 3, 20]))
def test_fast_sweep_equals_literal_on_graded_maps(grid: slamq.OccupancyMap, min_area: int) -> None:
    params = Params(min_area=min_area)
    fast = slamq.evaluate(grid, curve=True, min_area=min_area, threads=1)
    literal = reference.enclosed_curve(grid, params)
    assert list(fast.curve) == list(literal)
    assert fast.enclosed_areas == max(literal)
    assert fast.enclosed_unknown_value == int(np.argmax(literal))


def test_graded_corpus_style_map_has_many_distinct_binarisations() -> None:
    """A map whose Otsu threshold moves with u through many known values: the incremental
    path's case. Checked against the literal curve value by value."""
    rng = np.random.default_rng(7)
    h, w = 90, 110
    yy, xx = np.mgrid[0:h, 0:w]
    values = ((xx * 255) // (w - 1)).astype(np.uint8)          # a ramp: every level present
    values[::9, :] = 0                                           # walls
    values[:, ::11] = 0
    unknown = rng.random((h, w)) < 0.35
    grid = slamq.OccupancyMap(values, unknown)
    thresholds = set(slamq._core.otsu_table(grid.values, grid.unknown))
    assert len(thresholds) > 10, thresholds
    fast = slamq.evaluate(grid, curve=True)
    assert list(fast.curve) == reference.enclosed_curve(grid, Params())
