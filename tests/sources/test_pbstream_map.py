"""Cartographer submaps rasterised (slamq.sources.pbstream_map): streams built here with the
independent encoder of tests/_pbencode.py; expected cells derived in the comments."""

from __future__ import annotations

import math

import numpy as np
import pytest
from _pbencode import FREE, OCC, RES, f_msg, graph, grid2d, submap, write

from slamq import MapError, load_map
from slamq.sources.pbstream_map import read_pbstream_map


def one_wall() -> np.ndarray:
    """A 6 x 5 submap grid (ny=6, nx=5), all free, cell (x=1, y=3) occupied."""
    cells = np.full((6, 5), FREE, np.int64)
    cells[3, 1] = OCC
    return cells


def value_at(m, x: float, y: float) -> tuple[int, bool]:
    """The map's value and unknown flag at world point (x, y)."""
    c = int(math.floor((x - m.origin[0]) / m.resolution))
    r = m.shape[0] - 1 - int(math.floor((y - m.origin[1]) / m.resolution))
    return int(m.values[r, c]), bool(m.unknown[r, c])


def test_one_submap_lands_where_its_limits_say(tmp_path) -> None:
    # max corner (2.0, 1.0): cell (x, y) spans world x in [2.0 - (y+1) r, 2.0 - y r] and
    # y in [1.0 - (x+1) r, 1.0 - x r]; the wall cell (1, 3) is centred at (1.65, 0.85)
    p = write(tmp_path, graph({0: (0, 0, 0)}),
              submap(0, 0, (0, 0, 0), grid2d(one_wall(), (2.0, 1.0), (0, 0, 4, 5))))
    m = read_pbstream_map(p)
    assert m.resolution == RES and m.meta["kind"] == "pbstream" and m.meta["submaps"] == 1
    # 6 x 5 cells (x extent 0.6 m, y extent 0.5 m) plus 5 cells of padding on each side
    assert m.shape == (5 + 10, 6 + 10)
    # occupied: delta = 128 - 255: alpha 127 over the background 128 -> intensity 64,
    # occupancy round((1 - 64/255) * 100) = 75 -> pixel rint(255 * 25 / 100) = 64
    assert value_at(m, 1.65, 0.85) == (64, False)
    # free: delta = 127 added to 128 -> 255, occupancy 0 -> pixel 255
    assert value_at(m, 1.95, 0.95) == (255, False) and value_at(m, 1.45, 0.55) == (255, False)
    assert value_at(m, 1.2, 0.3)[1]  # padding: never observed, unknown
    assert int(m.known_count) == 30 and int((~m.unknown & (m.values < 128)).sum()) == 1


def test_the_optimised_pose_moves_and_turns_the_submap(tmp_path) -> None:
    # local pose (1, 0, 0), optimised global pose (5, 5, 90 deg): a local point q maps to
    # G * L^-1 * q = (5, 5) + R90 (q - (1, 0)); the wall centre (1.65, 0.85) -> (4.15, 5.65)
    p = write(tmp_path, graph({0: (5, 5, math.pi / 2)}),
              submap(0, 0, (1, 0, 0), grid2d(one_wall(), (2.0, 1.0), (0, 0, 4, 5))))
    m = read_pbstream_map(p)
    assert value_at(m, 4.15, 5.65) == (64, False)
    assert (~m.unknown & (m.values < 128)).sum() == 1 and m.known_count == 30
    assert m.shape == (6 + 10, 5 + 10)  # turned: x and y extents swap


def test_submaps_are_composited_in_id_order_and_cropped_to_their_known_box(tmp_path) -> None:
    free = np.full((6, 5), FREE, np.int64)
    cells = one_wall()
    cells[0, :] = 0  # unknown row: cropped off by the known box (y from 1)
    p = write(tmp_path, graph({0: (0, 0, 0), 1: (0, 0, 0)}),
              submap(0, 1, (0, 0, 0), grid2d(free, (2.0, 1.0), (0, 0, 4, 5))),
              submap(0, 0, (0, 0, 0), grid2d(cells, (2.0, 1.0), (0, 1, 4, 5))))
    m = read_pbstream_map(p)
    # submap 0 first: the wall (intensity 64) then submap 1's free cell adds 127 -> 191,
    # occupancy round((1 - 191/255) * 100) = 25 -> pixel rint(255 * 75 / 100) = 191
    assert value_at(m, 1.65, 0.85) == (191, False)
    assert value_at(m, 1.95, 0.95) == (255, False)  # known in submap 1 only


def test_load_map_reads_a_pbstream(tmp_path) -> None:
    p = write(tmp_path, graph({0: (0, 0, 0)}),
              submap(0, 0, (0, 0, 0), grid2d(one_wall(), (2.0, 1.0), (0, 0, 4, 5))))
    assert load_map(p).shape == read_pbstream_map(p).shape


@pytest.mark.parametrize("records, reason", [
    ((graph({0: (0, 0, 0)}),), "holds no 2D submap"),
    ((graph({}), submap(0, 0, (0, 0, 0), grid2d(one_wall(), (2.0, 1.0), (0, 0, 4, 5)))),
     r"submap \(0, 0\) has no pose in the pose graph"),
    ((graph({0: (0, 0, 0)}), f_msg(3, b"\xff\xff")), "corrupt pbstream"),
    ((graph({0: (0, 0, 0)}), f_msg(3, f_msg(3, b""))), "a 3D submap"),
])
def test_bad_streams_are_map_errors_naming_the_file(tmp_path, records, reason) -> None:
    p = write(tmp_path, *records)
    with pytest.raises(MapError, match=reason) as exc:
        read_pbstream_map(p)
    assert str(exc.value).startswith(str(p))


@pytest.mark.parametrize("declared, reason", [
    ((50, 60), "30 cell values for 50 x 60 cells"),
    ((50000, 60000), "50000 x 60000 cells is not a grid of 1 to 1073741824 cells"),
])
def test_limits_that_do_not_match_the_cells_are_refused(tmp_path, declared, reason) -> None:
    bad = grid2d(one_wall(), (2.0, 1.0), (0, 0, 4, 5), declared=declared)
    p = write(tmp_path, graph({0: (0, 0, 0)}), submap(0, 0, (0, 0, 0), bad))
    with pytest.raises(MapError, match=reason):
        read_pbstream_map(p)
