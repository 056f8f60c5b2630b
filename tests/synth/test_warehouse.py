"""The warehouse world kind: parallel racks with aisles between them, offices along one
wall, drivable down every aisle, and added without changing any earlier world."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from _drive import check_added_kind, drive_on_floor

from slamq.synth.worldgen import world


def _racks(w) -> list[tuple[float, float, float, float]]:
    """The racks: wall blobs of the hall at least 2 m long and 0.8-1.3 m deep, as (x0, y0,
    x1, y1) in metres."""
    aisles = [r["box"] for r in w.meta["rooms"] if r["name"].startswith("aisle")]
    lo, hi = min(b[1] for b in aisles) - 3.0, max(b[3] for b in aisles) + 3.0
    walls = (w.values == 0).astype(np.uint8)
    n, _, stats, _ = cv2.connectedComponentsWithStats(walls, connectivity=4)
    res, (ox, oy) = w.resolution, w.origin[:2]
    out = []
    for x, y, bw, bh, _area in stats[1:n]:
        long_, deep = bw * res, bh * res
        if long_ >= 2.0 and 0.8 <= deep <= 1.3:
            y1 = oy + (w.shape[0] - y) * res
            if lo <= y1 - deep and y1 <= hi:
                out.append((ox + x * res, y1 - deep, ox + (x + bw) * res, y1))
    return out


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_warehouse_racks_stand_in_parallel_rows_with_aisles_between(seed: int) -> None:
    w = world(seed, kind="warehouse")
    racks = _racks(w)
    # a row's racks: their centre lines within 0.2 m (an empty bay's posts stand out of
    # the rack's line by half a post, so a rack beside one is a cell deeper)
    centres = sorted((r[1] + r[3]) / 2 for r in racks)
    rows = [c for i, c in enumerate(centres) if i == 0 or c - centres[i - 1] > 0.2]
    assert len(rows) >= 2, racks
    gaps = np.diff(rows)
    # one rack's depth (0.9-1.2 m) plus one aisle (2.4-3.2 m) apart, every two rows alike
    assert ((gaps >= 3.3) & (gaps <= 4.4)).all() and np.ptp(gaps) < 0.2, gaps
    # two places in every aisle the drive visits, the two cross aisles at the ends too
    names = [r["name"] for r in w.meta["rooms"]]
    assert sum(n.startswith("aisle") for n in names) == 2 * (len(rows) + 1)
    assert {"end0", "end1"} <= set(names)
    assert {"warehouse", "aisles", "repetitive"} <= set(w.meta["features"])


def test_warehouse_world_can_be_driven_down_every_aisle() -> None:
    w = world(4, kind="warehouse")
    xy = drive_on_floor(w)                              # never inside a rack or a wall
    for room in w.meta["rooms"]:
        x0, y0, x1, y1 = room["box"]
        # every room is entered: the offices, the cross aisles at the ends, and both
        # places of every aisle (near its two ends: the drive goes down its length)
        inside = (xy[:, 0] > x0) & (xy[:, 0] < x1) & (xy[:, 1] > y0) & (xy[:, 1] < y1)
        assert inside.any(), room["name"]
        if room["name"].startswith("aisle"):
            gap = np.hypot(xy[:, 0] - (x0 + x1) / 2, xy[:, 1] - (y0 + y1) / 2).min()
            assert gap < 1.0, room["name"]


def test_warehouse_is_chosen_by_name_and_changes_no_existing_world() -> None:
    check_added_kind("warehouse")


def test_a_small_warehouse_still_has_a_row_of_racks() -> None:
    w = world(3, kind="warehouse", size=(12.0, 9.0))
    assert any(r["name"] == "aisle1-1" for r in w.meta["rooms"])
    assert (w.values == 254).any() and (w.values == 0).any()
