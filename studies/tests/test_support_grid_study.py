"""studies/support_grid_study.py: its resampler takes each fine cell by its exact area."""

from __future__ import annotations

import math

import numpy as np
import pytest
from support_grid_study import on_grid

from slamq.models import OccupancyMap


def _by_hand(m: OccupancyMap, res: float) -> tuple[np.ndarray, np.ndarray]:
    """on_grid by hand: every fine cell's overlap with every coarse cell, from the map's
    bottom-left corner."""
    fine = m.resolution
    occ = ((m.values < 128) & ~m.unknown)[::-1]
    known = (~m.unknown)[::-1]
    h, w = m.shape
    nh, nw = math.ceil(h * fine / res - 1e-9), math.ceil(w * fine / res - 1e-9)

    def overlap(n_fine: int, n_coarse: int) -> np.ndarray:
        lo = np.maximum.outer(np.arange(n_coarse) * res, np.arange(n_fine) * fine)
        hi = np.minimum.outer((np.arange(n_coarse) + 1) * res, (np.arange(n_fine) + 1) * fine)
        return np.clip(hi - lo, 0, None) / res

    ry, rx = overlap(h, nh), overlap(w, nw)
    o = ry @ occ.astype(float) @ rx.T
    k = ry @ known.astype(float) @ rx.T
    occupied = o >= min(0.2, 0.5 * fine / res) - 1e-6
    unknown = ~((k > 0.5 + 1e-6) | occupied)
    return occupied[::-1], unknown[::-1]


@pytest.mark.parametrize("res", [0.07, 0.1, 0.13, 0.125, 0.0501, 0.2])
def test_each_fine_cell_counts_by_its_area(res: float) -> None:
    rng = np.random.default_rng(int(res * 1e4))
    values = np.where(rng.random((23, 31)) < 0.15, 0, 254).astype(np.uint8)
    unknown = rng.random(values.shape) < 0.3
    m = OccupancyMap(values, unknown, 0.05, (1.5, -2.0, 0.4))
    c = on_grid(m, res)
    occupied, hidden = _by_hand(m, res)
    assert c.resolution == res and c.origin == m.origin
    assert np.array_equal(c.unknown, hidden)
    assert np.array_equal(c.values == 0, occupied)
    assert np.array_equal(c.values == 254, ~occupied & ~hidden)
    assert on_grid(m, 0.05) is m
    with pytest.raises(ValueError, match="finer"):
        on_grid(m, 0.04)


def test_a_wall_one_fine_cell_thick_leaves_a_wall_at_any_coarser_grid() -> None:
    for res in (0.06, 0.07, 0.1, 0.13, 0.25):
        for col in range(3, 17):
            img = np.full((20, 20), 254, np.uint8)
            img[:, col] = 0
            c = on_grid(OccupancyMap(img, np.zeros(img.shape, bool), 0.05), res)
            assert (c.values[-1] == 0).sum() >= 1, (res, col)
