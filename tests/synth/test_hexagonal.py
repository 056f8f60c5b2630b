"""The hexagonal world kind: walls at 0, 60 and 120 degrees only, drivable, and added
without changing any world of the six kinds before it."""

from __future__ import annotations

import hashlib

import cv2
import numpy as np
from _drive import drive_on_floor

from slamq.synth.worldgen import DEFAULT_KINDS, KINDS, world, worlds


def test_hexagonal_walls_run_at_0_60_120_degrees() -> None:
    w = world(1, kind="hexagonal")
    walls = (w.values == 0).astype(np.uint8)
    lines = cv2.HoughLinesP(walls * 255, 1, np.pi / 360, 40, minLineLength=30, maxLineGap=3)
    assert lines is not None and len(lines) >= 12
    angles = [np.degrees(np.arctan2(-(y1 - y0), x1 - x0)) % 180
              for x0, y0, x1, y1 in lines.reshape(-1, 4).astype(float)]
    off = [min(abs(a - t) for t in (0, 60, 120, 180)) for a in angles]
    assert max(off) < 3.0, sorted(angles)
    # walls in each of the three directions, none at 90 degrees
    for t in (0, 60, 120):
        assert any(min(abs(a - t), 180 - abs(a - t)) < 3 for a in angles), t
    assert not any(abs(a - 90) < 10 for a in angles)
    assert "not rectilinear" in w.meta["features"]


def test_hexagonal_world_can_be_driven_through_its_rooms() -> None:
    w = world(2, kind="hexagonal")
    xy = drive_on_floor(w)                              # never inside a wall
    assert len(xy) > 200
    assert np.ptp(xy[:, 0]) > 8.0 and np.ptp(xy[:, 1]) > 6.0   # crosses the building


def test_a_new_kind_changes_no_existing_world() -> None:
    assert "hexagonal" in KINDS and "hexagonal" not in DEFAULT_KINDS
    assert [w.meta["kind"] for w in worlds(7, resolution=0.2)] == [*DEFAULT_KINDS, "office"]
    # office seed 3 as generated before the kind was added
    digest = hashlib.md5(world(3, kind="office").values.tobytes()).hexdigest()
    assert digest == "80bcf22a2a197472d7a5b94ea4a7e45e"
