"""The house world kind: an L-shaped dwelling with an open-plan living room, a curved
wall, free-standing furniture and a hallway to bedrooms, drivable into every room, and
added without changing any earlier world."""

from __future__ import annotations

import numpy as np
import pytest
from _drive import check_added_kind, drive_on_floor

from slamq.synth.worldgen import MARGIN, world


def _cell(w, x: float, y: float) -> tuple[int, int]:
    res, (ox, oy) = w.resolution, w.origin[:2]
    return w.shape[0] - 1 - int((y - oy) / res), int((x - ox) / res)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_house_is_l_shaped_with_a_curved_corner(seed: int) -> None:
    w = world(seed, kind="house")
    W, H = w.meta["size"]
    known = ~w.unknown
    # the L's notch: the north-east corner is outside the building, the other three in
    assert not known[_cell(w, W - 0.3, H - 0.3)]
    assert known[_cell(w, 0.3, H - 0.3)] and known[_cell(w, W - 0.3, 0.3)]
    # the south-west corner is rounded: its corner cell is outside, while a straight wall
    # runs along the west and the south further from it
    assert not known[_cell(w, 0.1, 0.1)]
    assert w.values[_cell(w, 0.0, H * 0.45)] == 0 and w.values[_cell(w, W * 0.9, 0.0)] == 0
    # the curve: walls whose distance from the corner's centre is one radius, at many angles
    walls = np.argwhere(w.values == 0)
    xs = walls[:, 1] * w.resolution - MARGIN
    ys = (w.shape[0] - 1 - walls[:, 0]) * w.resolution - MARGIN
    arc = (xs > 0.2) & (ys > 0.2) & (xs < 1.0) & (ys < 1.0)
    assert arc.sum() > 10
    assert {"house", "curved wall", "clutter"} <= set(w.meta["features"])


def test_house_rooms_are_of_unequal_sizes_off_a_hallway() -> None:
    w = world(2, kind="house")
    rooms = {r["name"]: r["box"] for r in w.meta["rooms"]}
    assert {"hallway", "living", "kitchen"} <= set(rooms)
    beds = [b for n, b in rooms.items() if n.startswith("bedroom")]
    widths = sorted(round(b[2] - b[0], 2) for b in beds)
    assert len(beds) >= 2 and widths[-1] - widths[0] > 0.3, widths
    hall = rooms["hallway"]
    assert 1.2 <= hall[3] - hall[1] <= 1.5 + 1e-9
    # every bedroom sits on the hallway's north side
    assert all(abs(b[1] - hall[3]) < 1e-6 for b in beds)


def test_house_can_be_driven_into_every_room() -> None:
    w = world(4, kind="house")
    xy = drive_on_floor(w)                              # never inside furniture or a wall
    for room in w.meta["rooms"]:
        x0, y0, x1, y1 = room["box"]
        inside = (xy[:, 0] > x0) & (xy[:, 0] < x1) & (xy[:, 1] > y0) & (xy[:, 1] < y1)
        assert inside.any(), room["name"]


def test_house_is_chosen_by_name_and_changes_no_existing_world() -> None:
    check_added_kind("house")


@pytest.mark.parametrize("size", [(8.0, 6.0), (10.0, 8.0), (30.0, 20.0)])
def test_a_house_of_any_allowed_size_has_its_rooms(size: tuple[float, float]) -> None:
    w = world(1, kind="house", size=size)
    names = {r["name"] for r in w.meta["rooms"]}
    assert {"hallway", "living", "kitchen", "bedroom0"} <= names
    assert (w.values == 254).any() and (w.values == 0).any()
