"""Hypothesis strategies for occupancy maps (shared by the conformance and fast-sweep tests).

Every strategy draws a small description (size, kind, a seed, a few densities) and builds
the arrays with numpy from that seed, so that maps up to ~200x200 cost nothing to draw
and still shrink toward small sizes and simple kinds.

Kinds
-----
``graded``      smooth probability field quantised to many grey levels (``mode: scale``
                maps), unknown where the field is near 0.5 plus random holes.
``noise``       i.i.d. values over a random number of grey levels, random unknown mask.
``three_level`` map_saver shades 0 / 205 / 254 in random rectangles; 205 is unknown.
``rooms``       unknown canvas with rectangular wall rings (some touching or cut by the
                image border, some with doors), free interiors, shared walls.
``lines``       free ground with thin dark lines (1 cell, any direction) and unknown blobs.
``single``      one value everywhere except one cell (known or unknown).
``no_known``    every cell unknown, random values underneath.

Examples
--------
>>> from hypothesis import given, settings
>>> @settings(max_examples=5)
... @given(occupancy_maps(max_side=20))
... def check(grid):
...     assert grid.values.shape == grid.unknown.shape
>>> check()
"""

from __future__ import annotations

import cv2
import numpy as np
from hypothesis import strategies as st

from slamq import OccupancyMap

__all__ = ["KINDS", "graded_maps", "map_sizes", "occupancy_maps", "seeds"]

KINDS = ("graded", "noise", "three_level", "rooms", "lines", "single", "no_known")

seeds = st.integers(min_value=0, max_value=2**32 - 1)


def map_sizes(min_side: int = 1, max_side: int = 200) -> st.SearchStrategy[tuple[int, int]]:
    """``(H, W)`` with both sides in ``min_side..max_side``, biased to small and thin maps."""
    small = st.integers(min_side, max(min_side, min(max_side, 8)))
    medium = st.integers(max(min_side, min(max_side, 9)), max(min_side, min(max_side, 64)))
    side = st.one_of(small, medium, st.integers(min_side, max_side))
    return st.tuples(side, side)


def _graded(rng: np.random.Generator, h: int, w: int) -> OccupancyMap:
    # A smooth random field: coarse noise blown up with cubic interpolation.
    ch, cw = max(1, h // int(rng.integers(2, 12))), max(1, w // int(rng.integers(2, 12)))
    coarse = rng.uniform(0.0, 1.0, (ch, cw)).astype(np.float32)
    field = cv2.resize(coarse, (w, h), interpolation=cv2.INTER_CUBIC)
    field = np.clip(field + rng.normal(0.0, 0.05, (h, w)), 0.0, 1.0)
    levels = int(rng.integers(2, 256))
    values = np.rint(np.rint(field * (levels - 1)) * (255.0 / (levels - 1))).astype(np.uint8)
    band = float(rng.uniform(0.0, 0.15))
    unknown = np.abs(field - 0.5) < band
    unknown |= rng.uniform(0.0, 1.0, (h, w)) < float(rng.uniform(0.0, 0.1))
    return OccupancyMap(values, unknown)


def _noise(rng: np.random.Generator, h: int, w: int) -> OccupancyMap:
    palette = rng.integers(0, 256, int(rng.integers(1, 12)))
    values = rng.choice(palette, (h, w)).astype(np.uint8)
    unknown = rng.uniform(0.0, 1.0, (h, w)) < float(rng.uniform(0.0, 1.0))
    return OccupancyMap(values, unknown)


def _rect(rng: np.random.Generator, h: int, w: int) -> tuple[int, int, int, int]:
    """A rectangle ``(r0, c0, r1, c1)`` (inclusive) that may stick out of the image."""
    r0 = int(rng.integers(-2, max(h, 1)))
    c0 = int(rng.integers(-2, max(w, 1)))
    r1 = r0 + int(rng.integers(1, max(2, h)))
    c1 = c0 + int(rng.integers(1, max(2, w)))
    return r0, c0, r1, c1


def _three_level(rng: np.random.Generator, h: int, w: int) -> OccupancyMap:
    values = np.full((h, w), 205, np.uint8)
    for _ in range(int(rng.integers(1, 8))):
        r0, c0, r1, c1 = _rect(rng, h, w)
        values[max(r0, 0) : max(r1 + 1, 0), max(c0, 0) : max(c1 + 1, 0)] = rng.choice(
            [0, 205, 254]
        )
    return OccupancyMap(values, values == 205)


def _rooms(rng: np.random.Generator, h: int, w: int) -> OccupancyMap:
    values = np.full((h, w), 205, np.uint8)
    unknown = np.ones((h, w), bool)
    free_value = int(rng.choice([254, 255, int(rng.integers(150, 256))]))
    wall_value = int(rng.choice([0, int(rng.integers(0, 100))]))
    for _ in range(int(rng.integers(1, 6))):
        r0, c0, r1, c1 = _rect(rng, h, w)
        thick = int(rng.integers(1, 3))
        rows = slice(max(r0, 0), max(r1 + 1, 0))
        cols = slice(max(c0, 0), max(c1 + 1, 0))
        values[rows, cols] = wall_value
        unknown[rows, cols] = False
        inner_rows = slice(max(r0 + thick, 0), max(r1 + 1 - thick, 0))
        inner_cols = slice(max(c0 + thick, 0), max(c1 + 1 - thick, 0))
        values[inner_rows, inner_cols] = free_value
        if rng.uniform() < 0.3 and r1 - r0 > 2:  # a door in the left wall
            r = int(rng.integers(r0 + 1, r1))
            if 0 <= r < h:
                values[r, max(c0, 0) : max(c0 + thick, 0)] = free_value
    if rng.uniform() < 0.3:  # an inner dividing wall
        c = int(rng.integers(0, w))
        values[:, c] = np.where(unknown[:, c], values[:, c], wall_value)
    return OccupancyMap(values, unknown)


def _lines(rng: np.random.Generator, h: int, w: int) -> OccupancyMap:
    values = np.full((h, w), int(rng.choice([254, 255, 230])), np.uint8)
    for _ in range(int(rng.integers(1, 10))):
        p0 = (int(rng.integers(-5, w + 5)), int(rng.integers(-5, h + 5)))
        p1 = (int(rng.integers(-5, w + 5)), int(rng.integers(-5, h + 5)))
        cv2.line(values, p0, p1, int(rng.integers(0, 120)), 1, lineType=cv2.LINE_8)
    unknown = np.zeros((h, w), bool)
    for _ in range(int(rng.integers(0, 4))):
        r0, c0, r1, c1 = _rect(rng, h, w)
        unknown[max(r0, 0) : max(r1 + 1, 0), max(c0, 0) : max(c1 + 1, 0)] = True
    return OccupancyMap(values, unknown)


def _single(rng: np.random.Generator, h: int, w: int) -> OccupancyMap:
    values = np.full((h, w), int(rng.integers(0, 256)), np.uint8)
    unknown = np.full((h, w), bool(rng.uniform() < 0.5))
    r, c = int(rng.integers(0, h)), int(rng.integers(0, w))
    values[r, c] = int(rng.integers(0, 256))
    unknown[r, c] = bool(rng.uniform() < 0.5)
    return OccupancyMap(values, unknown)


def _no_known(rng: np.random.Generator, h: int, w: int) -> OccupancyMap:
    values = rng.integers(0, 256, (h, w)).astype(np.uint8)
    return OccupancyMap(values, np.ones((h, w), bool))


_BUILDERS = {
    "graded": _graded,
    "noise": _noise,
    "three_level": _three_level,
    "rooms": _rooms,
    "lines": _lines,
    "single": _single,
    "no_known": _no_known,
}


@st.composite
def occupancy_maps(
    draw: st.DrawFn,
    min_side: int = 1,
    max_side: int = 200,
    kinds: tuple[str, ...] = KINDS,
) -> OccupancyMap:
    """An :class:`slamq.OccupancyMap` of one of ``kinds`` (see the module docstring)."""
    h, w = draw(map_sizes(min_side, max_side))
    kind = draw(st.sampled_from(kinds))
    rng = np.random.default_rng(draw(seeds))
    grid = _BUILDERS[kind](rng, h, w)
    return OccupancyMap(grid.values, grid.unknown, source=f"<hypothesis {kind} {h}x{w}>")


def graded_maps(min_side: int = 1, max_side: int = 200) -> st.SearchStrategy[OccupancyMap]:
    """Graded maps (many grey levels) with random unknown masks: the fast sweep's hard case."""
    return occupancy_maps(min_side=min_side, max_side=max_side, kinds=("graded", "noise"))
