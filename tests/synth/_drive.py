"""A planned drive through a generated world, checked to stay on its free cells (the
world kinds' tests). Not part of the package."""

from __future__ import annotations

import numpy as np

from slamq.models import OccupancyMap
from slamq.synth.planner import drive


def drive_on_floor(w: OccupancyMap, seed: int = 0) -> np.ndarray:
    """The ``(x, y)`` of ``drive(w, seed)``'s poses, after checking that every one of them
    lies on a free cell of ``w`` (never inside a wall, a rack or a pillar)."""
    xy = np.asarray(drive(w, seed=seed).poses)[:, :2]
    res, (ox, oy) = w.resolution, w.origin[:2]
    cols = ((xy[:, 0] - ox) / res).astype(int)
    rows = w.shape[0] - 1 - ((xy[:, 1] - oy) / res).astype(int)
    assert (w.values[rows, cols] == 254).all(), "the drive enters a wall"
    return xy
