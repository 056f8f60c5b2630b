"""The simulator's laser: the Rust ray caster against its numpy twin, thread counts,
geometry, and bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from slamq import OccupancyMap
from slamq.errors import SlamqError
from slamq.synth import LaserSpec
from slamq.synth.sensors import cast, cast_numpy, laser_scans


def _room(h: int = 40, w: int = 60, res: float = 0.05,
          origin: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> OccupancyMap:
    v = np.full((h, w), 254, np.uint8)
    v[0, :] = v[-1, :] = v[:, 0] = v[:, -1] = 0
    v[10:25, 30] = 0
    v[30, 5:20] = 0
    return OccupancyMap(v, np.zeros_like(v, bool), res, origin)


@st.composite
def worlds_and_poses(draw: st.DrawFn) -> tuple[OccupancyMap, np.ndarray, np.ndarray, float]:
    h = draw(st.integers(1, 24))
    w = draw(st.integers(1, 24))
    density = draw(st.sampled_from([0.0, 0.05, 0.2, 0.6]))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    v = np.where(rng.random((h, w)) < density, 0, 254).astype(np.uint8)
    res = draw(st.sampled_from([0.05, 0.1, 0.37, 1.0]))
    origin = (draw(st.floats(-3, 3)), draw(st.floats(-3, 3)),
              draw(st.sampled_from([0.0, 0.0, 0.4, -2.0])))
    world = OccupancyMap(v, np.zeros_like(v, bool), res, origin)
    n = draw(st.integers(1, 4))
    span = max(h, w) * res + 4
    coord = st.floats(-span, span, allow_nan=False)
    poses = np.array([[draw(coord), draw(coord), draw(st.floats(-7, 7))] for _ in range(n)])
    beams = draw(st.integers(1, 40))
    angles = np.linspace(-math.pi, math.pi, beams) + draw(st.floats(-0.1, 0.1))
    max_range = draw(st.sampled_from([0.3, 2.0, 20.0, math.inf]))
    return world, poses, angles, max_range


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(worlds_and_poses())
def test_rust_equals_the_numpy_reference(case) -> None:
    world, poses, angles, max_range = case
    rust = cast(world, poses, angles, max_range, threads=1)
    ref = cast_numpy(world, poses, angles, max_range)
    assert rust.shape == ref.shape == (len(poses), len(angles))
    assert np.array_equal(np.isinf(rust), np.isinf(ref))
    finite = np.isfinite(rust)
    np.testing.assert_allclose(rust[finite], ref[finite], rtol=0, atol=1e-5)
    assert (rust[finite] >= 0).all() and (rust[finite] <= max_range + 1e-9).all()


def test_thread_counts_give_the_same_ranges() -> None:
    world = _room(200, 300)
    rng = np.random.default_rng(3)
    poses = np.column_stack([rng.uniform(0.1, 14.9, 300), rng.uniform(0.1, 9.9, 300),
                             rng.uniform(-4, 4, 300)])
    angles = LaserSpec().angles()
    one = cast(world, poses, angles, 20.0, threads=1)
    assert np.array_equal(one, cast(world, poses, angles, 20.0, threads=2))
    assert np.array_equal(one, cast(world, poses, angles, 20.0, threads=None))


def test_ranges_reach_the_face_of_the_wall() -> None:
    world = _room()  # 3 x 2 m, walls one cell thick on the border
    # from (1, 1): east the inner wall's face at x = 1.5, north, west and south the border
    # walls' inner faces (y = 1.95, x = 0.05, y = 0.05; the short wall ends at x = 1.0)
    r = cast(world, [[1.0, 1.0, 0.0]], [0.0, math.pi / 2, math.pi, -math.pi / 2], 20.0)
    np.testing.assert_allclose(r[0], [0.5, 0.95, 0.95, 0.95], atol=1e-12)
    r = cast(world, [[0.99, 1.0, -math.pi / 2]], [0.0], 20.0)
    assert r[0, 0] == pytest.approx(0.5)
    # a wall through a transparent cell: the beam goes on to the next wall
    glass = np.zeros(world.shape, bool)
    glass[10:25, 30] = True
    clear = OccupancyMap(world.values, world.unknown, 0.05, meta={"transparent": glass})
    assert cast(world, [[0.5, 1.4, 0.0]], [0.0], 20.0)[0, 0] == pytest.approx(1.0)
    assert cast(clear, [[0.5, 1.4, 0.0]], [0.0], 20.0)[0, 0] == pytest.approx(2.45)


def test_unknown_cells_and_the_outside_stop_nothing() -> None:
    world = _room()
    unknown = np.zeros(world.shape, bool)
    unknown[:, -1] = True
    m = OccupancyMap(world.values, unknown, 0.05)
    assert cast(m, [[2.0, 1.0, 0.0]], [0.0], 20.0)[0, 0] == math.inf
    assert cast(world, [[2.0, 1.0, 0.0]], [0.0], 20.0)[0, 0] == pytest.approx(0.95)


def test_laser_scans_noise_min_range_and_offset() -> None:
    world = _room()
    spec = LaserSpec(beams=181, fov=math.pi, range_noise=0.0)
    gt = np.array([[1.0, 1.0, 0.0], [1.2, 0.8, 0.3]])
    exact = laser_scans(world, gt, spec)
    assert exact.dtype == np.float32 and exact.shape == (2, 181)
    noisy = laser_scans(world, gt, LaserSpec(beams=181, fov=math.pi, range_noise=0.01), seed=4)
    assert np.array_equal(noisy, laser_scans(world, gt, LaserSpec(
        beams=181, fov=math.pi, range_noise=0.01), seed=4))
    d = (noisy - exact)[np.isfinite(exact)]
    assert 0.005 < d.std() < 0.015
    near = laser_scans(world, gt, LaserSpec(beams=181, fov=math.pi, range_noise=0.0,
                                            min_range=0.5))
    assert np.isinf(near[exact < 0.5]).all()
    # a laser 0.1 m ahead of the robot sees the inner wall 0.1 m nearer
    ahead = laser_scans(world, gt[:1], LaserSpec(beams=1, fov=0.0, range_noise=0.0,
                                                offset=(0.1, 0.0, 0.0)))
    assert ahead[0, 0] == pytest.approx(0.4, abs=1e-6)


@pytest.mark.parametrize("poses, angles, max_range, match", [
    (np.zeros((2, 2)), [0.0], 1.0, "shape"),
    ([[np.nan, 0.0, 0.0]], [0.0], 1.0, "finite"),
    ([[0.0, 0.0, 0.0]], [[0.0]], 1.0, "1-D"),
    ([[0.0, 0.0, 0.0]], [np.inf], 1.0, "finite"),
    ([[0.0, 0.0, 0.0]], [0.0], 0.0, "max_range"),
    ([[0.0, 0.0, 0.0]], [0.0], np.nan, "max_range"),
])
def test_bad_input_is_a_clear_error(poses, angles, max_range, match) -> None:
    with pytest.raises(SlamqError, match=match):
        cast(_room(), poses, angles, max_range)
    with pytest.raises(SlamqError, match=match):
        cast_numpy(_room(), poses, angles, max_range)


def test_the_core_checks_its_own_arguments() -> None:
    from slamq import _core

    grid = np.zeros((4, 4), np.uint8)
    pose = np.zeros((1, 3))
    ang = np.zeros(1)
    with pytest.raises(ValueError, match="resolution"):
        _core.raycast(grid, -1.0, (0, 0, 0), pose, ang, 1.0)
    with pytest.raises(ValueError, match="origin"):
        _core.raycast(grid, 1.0, (math.nan, 0, 0), pose, ang, 1.0)
    with pytest.raises(ValueError, match="poses"):
        _core.raycast(grid, 1.0, (0, 0, 0), np.zeros((1, 2)), ang, 1.0)
    with pytest.raises(ValueError, match="contiguous"):
        _core.raycast(np.zeros((4, 8), np.uint8)[:, ::2], 1.0, (0, 0, 0), pose, ang, 1.0)
    with pytest.raises(ValueError, match="zero cells"):
        _core.raycast(np.zeros((0, 4), np.uint8), 1.0, (0, 0, 0), pose, ang, 1.0)
    assert _core.raycast(grid, 1.0, (0, 0, 0), np.zeros((0, 3)), ang, 1.0).shape == (0, 1)
    assert _core.raycast(grid, 1.0, (0, 0, 0), pose, np.zeros(0), 1.0).shape == (1, 0)
