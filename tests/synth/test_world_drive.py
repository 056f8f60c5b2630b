"""Worlds and drives: determinism per seed, map_server round trips, collision-free paths
that close their loop, bad input."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import slamq
from slamq.errors import MapError, SlamqError
from slamq.synth import KINDS, drive, load_world, save_world, world
from slamq.synth.planner import clearance

SMALL = (10.0, 8.0)


def _exact_clearance(w: slamq.OccupancyMap, xy: np.ndarray, reach: float) -> np.ndarray:
    """The exact distance from each point to the nearest obstacle cell (occupied or
    unknown), looked for within ``reach`` metres."""
    res = w.resolution
    obstacle = (w.values < 128) | w.unknown
    h = w.shape[0]
    out = np.full(len(xy), np.inf)
    k = int(math.ceil(reach / res)) + 1
    for i, (x, y) in enumerate(xy):
        c = int((x - w.origin[0]) // res)
        r = h - 1 - int((y - w.origin[1]) // res)
        rs, cs = np.nonzero(obstacle[max(r - k, 0):r + k + 1, max(c - k, 0):c + k + 1])
        if not len(rs):
            continue
        rs, cs = rs + max(r - k, 0), cs + max(c - k, 0)
        x0 = w.origin[0] + cs * res
        y0 = w.origin[1] + (h - 1 - rs) * res
        dx = np.maximum(np.maximum(x0 - x, x - (x0 + res)), 0.0)
        dy = np.maximum(np.maximum(y0 - y, y - (y0 + res)), 0.0)
        out[i] = np.hypot(dx, dy).min()
    return out


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_worlds_are_seeded_and_map_server_shaped(kind: str) -> None:
    size = (16.0, 8.0) if kind == "corridor" else SMALL
    a = world(5, kind=kind, size=size)
    b = world(5, kind=kind, size=size)
    c = world(6, kind=kind, size=size)
    assert np.array_equal(a.values, b.values)
    assert np.array_equal(a.meta["transparent"], b.meta["transparent"])
    assert not np.array_equal(a.values, c.values) or kind == "symmetric"
    assert set(np.unique(a.values)) == {0, 205, 254}
    assert np.array_equal(a.unknown, a.values == 205)
    assert a.resolution == 0.05 and a.origin == (-0.5, -0.5, 0.0)
    assert a.meta["kind"] == kind and a.meta["rooms"]
    assert not (a.meta["transparent"] & (a.values != 0)).any()
    # the building is closed: no free cell touches the unknown outside
    free = a.values == 254
    outside = a.unknown
    assert not (free[1:, :] & outside[:-1, :]).any() and not (free[:, 1:] & outside[:, :-1]).any()
    assert not (free[:-1, :] & outside[1:, :]).any() and not (free[:, :-1] & outside[:, 1:]).any()


def test_features_of_the_hard_kinds() -> None:
    hall = world(0, kind="hall", size=SMALL)
    assert hall.meta["transparent"].any() and "open space" in hall.meta["features"]
    assert "long corridor" in world(0, kind="corridor", size=(16.0, 8.0)).meta["features"]
    sym = world(0, kind="symmetric", size=SMALL)
    # turned by 180 degrees about the building's centre, the plan is the same
    inner = sym.values[10:-10, 10:-10]
    assert np.array_equal(inner, inner[::-1, ::-1])


def test_world_round_trip_and_any_map_as_a_world(tmp_path: Path, test_data: Path) -> None:
    w = world(2, kind="mixed", size=SMALL)
    back = load_world(save_world(w, tmp_path / "w.yaml"))
    assert np.array_equal(back.values, w.values)
    assert np.array_equal(back.meta["transparent"], w.meta["transparent"])
    assert back.meta["rooms"] == w.meta["rooms"]
    assert slamq.load_map(tmp_path / "w.yaml").resolution == 0.05
    office = load_world(test_data / "slam_comparison_tools/ground_truths/"
                        "office_ground_truth.yaml")
    assert office.meta["kind"] == "file" and "transparent" not in office.meta
    d = drive(office, seed=0, length=40.0)
    assert len(d) > 50


def test_bad_worlds_are_clear_errors(tmp_path: Path) -> None:
    with pytest.raises(SlamqError, match="unknown world kind 'castle'"):
        world(0, kind="castle")
    with pytest.raises(SlamqError, match="at least 8 x 6"):
        world(0, size=(3.0, 3.0))
    with pytest.raises(SlamqError, match="resolution"):
        world(0, resolution=0.0)
    with pytest.raises(MapError, match="no such world file"):
        load_world(tmp_path / "none.yaml")
    (tmp_path / "junk.yaml").write_text("image: junk.pgm\nresolution: 0.05\n"
                                        "origin: [0, 0, 0]\n")
    with pytest.raises(MapError, match="junk"):
        load_world(tmp_path / "junk.yaml")


@pytest.mark.parametrize("kind", ["office", "loop", "hall"])
def test_drive_is_seeded_collision_free_and_closes_its_loop(kind: str) -> None:
    w = world(1, kind=kind, size=SMALL)
    d = drive(w, seed=3, pauses=1, kidnaps=1)
    again = drive(w, seed=3, pauses=1, kidnaps=1)
    assert np.array_equal(d.poses, again.poses)
    assert not np.array_equal(d.poses, drive(w, seed=4).poses)
    assert np.allclose(np.diff(d.stamps), 0.1)
    # every pose keeps the clearance (exactly, to the cells' edges)
    near = _exact_clearance(w, d.poses[:, :2], 0.5)
    assert near.min() >= 0.35
    assert (clearance(w)[w.shape[0] - 1 - ((d.poses[:, 1] + 0.5) // 0.05).astype(int),
                         ((d.poses[:, 0] + 0.5) // 0.05).astype(int)] >= 0.35).all()
    # back to the start: a closed loop
    assert np.allclose(d.poses[0, :2], d.poses[-1, :2])
    # speed and turn rate are bounded (but at the kidnap)
    step = np.hypot(*np.diff(d.poses[:, :2], axis=0).T)
    turn = np.abs((np.diff(d.poses[:, 2]) + np.pi) % (2 * np.pi) - np.pi)
    moved = np.ones(len(step), bool)
    moved[np.array(d.meta["kidnaps"], int) - 1] = False
    assert step[moved].max() <= 0.05 + 1e-9
    assert turn[moved].max() <= math.radians(6.0) + 1e-9
    assert len(d.meta["kidnaps"]) == 1 and len(d.meta["pauses"]) == 1
    assert len(d.meta["waypoints"]) >= 3


def test_drive_length_and_laps() -> None:
    w = world(0, kind="office", size=SMALL)
    short = drive(w, seed=0, length=12.0)
    full = drive(w, seed=0)
    twice = drive(w, seed=0, laps=2)
    assert short.meta["length"] < full.meta["length"]
    assert twice.meta["length"] == pytest.approx(2 * full.meta["length"], rel=0.02)


def test_drive_bad_input() -> None:
    w = world(0, kind="office", size=SMALL)
    with pytest.raises(SlamqError, match="speed"):
        drive(w, speed=0.0)
    with pytest.raises(SlamqError, match="no place keeps"):
        drive(w, clearance_m=5.0)
    with pytest.raises(SlamqError, match="laps"):
        drive(w, laps=0)


@pytest.mark.parametrize("kind", sorted(KINDS))
def test_every_room_is_visited(kind: str) -> None:
    for seed in (21, 22):
        w = world(seed, kind=kind)
        d = drive(w, seed=seed)
        # one waypoint per room, the start twice (it closes the tour)
        assert len(d.meta["waypoints"]) == len(w.meta["rooms"]) + 1, (kind, seed)
