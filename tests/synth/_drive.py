"""For the world kinds' tests: a planned drive through a generated world, checked to stay
on its free cells, and the checks every kind added after the first six passes. Not part of
the package."""

from __future__ import annotations

import hashlib

import numpy as np

from slamq.models import OccupancyMap
from slamq.synth.planner import drive
from slamq.synth.worldgen import DEFAULT_KINDS, KINDS, world


def drive_on_floor(w: OccupancyMap, seed: int = 0) -> np.ndarray:
    """The ``(x, y)`` of ``drive(w, seed)``'s poses, after checking that every one of them
    lies on a free cell of ``w`` (never inside a wall, a rack or a pillar)."""
    xy = np.asarray(drive(w, seed=seed).poses)[:, :2]
    res, (ox, oy) = w.resolution, w.origin[:2]
    cols = ((xy[:, 0] - ox) / res).astype(int)
    rows = w.shape[0] - 1 - ((xy[:, 1] - oy) / res).astype(int)
    assert (w.values[rows, cols] == 254).all(), "the drive enters a wall"
    return xy


#: md5 of the values of worlds drawn before each later kind was added: a new kind must
#: leave every one of them as it was.
EARLIER_WORLDS = {("office", 3): "80bcf22a2a197472d7a5b94ea4a7e45e",
                  ("hexagonal", 2): "93b970718cbf82cca0923ddcbbe0143d",
                  ("wing", 2): "fccaa35093fe2bc5dcfb46b52bf7af38",
                  ("warehouse", 4): "e60c92eb6f24f94d22d9ab7d0838396b"}


def check_added_kind(kind: str) -> None:
    """``kind`` is chosen by name only (not in the default cycle), the same seed draws the
    same world and another seed another, and no world of :data:`EARLIER_WORLDS` changed."""
    assert kind in KINDS and kind not in DEFAULT_KINDS
    a, b = world(5, kind=kind), world(5, kind=kind)
    assert a.values.tobytes() == b.values.tobytes()
    assert a.values.tobytes() != world(6, kind=kind).values.tobytes()
    for (k, seed), digest in EARLIER_WORLDS.items():
        assert hashlib.md5(world(seed, kind=k).values.tobytes()).hexdigest() == digest, k
