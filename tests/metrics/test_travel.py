"""How far one path travels against another (docs/spec.md 7d): slamq.travel_ratio."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import slamq
from slamq import Trajectory, TrajectoryError


def _drive(t: np.ndarray, scale: float = 1.0) -> Trajectory:
    """A drive round a 10 m x 6 m rectangle at 0.5 m/s, its positions times ``scale``."""
    s = (0.5 * t) % 32.0
    x = np.select([s < 10, s < 16, s < 26], [s, 10 + 0 * s, 26 - s], 0 * s)
    y = np.select([s < 10, s < 16, s < 26], [0 * s, s - 10, 6 + 0 * s], 32 - s)
    return Trajectory.from_xy_yaw(t, scale * x, scale * y, np.zeros_like(t))


T = np.arange(0.0, 120.0, 0.1)


@pytest.mark.parametrize("scale", [0.9, 0.97, 1.0, 1.05])
def test_a_path_drawn_smaller_travels_less_by_its_scale(scale: float) -> None:
    a, b = _drive(T, scale), _drive(T)
    assert slamq.travel_ratio(a, b) == pytest.approx(scale, rel=1e-9)
    assert slamq.travel_ratio(b, a) == pytest.approx(1 / scale, rel=1e-9)


def test_frames_and_stamps_do_not_matter() -> None:
    """Another frame (turned and moved) and poses at other times: the same travel."""
    b = _drive(T)
    c, s = math.cos(0.7), math.sin(0.7)
    xy = b.positions[:, :2] @ np.array([[c, s], [-s, c]]) + [3.0, -2.0]
    turned = Trajectory.from_xy_yaw(T, xy[:, 0], xy[:, 1], np.zeros_like(T))
    assert slamq.travel_ratio(turned, b) == pytest.approx(1.0, rel=1e-9)
    sparse = b.subset(np.arange(0, len(T), 7))  # every 0.7 s, as graph nodes are
    assert slamq.travel_ratio(sparse, b) == pytest.approx(1.0, rel=1e-9)


def test_a_matcher_that_sticks_and_jumps_is_not_counted_long() -> None:
    """A path that stands still, then jumps to catch up, every 2 s: over windows of 10 s it
    travels what the true path does, though the sum of its steps is longer."""
    b = _drive(T)
    held = T - (T % 2.0)
    a = _drive(held)
    a = Trajectory.from_xy_yaw(T, a.positions[:, 0], a.positions[:, 1], np.zeros_like(T))
    assert slamq.travel_ratio(a, b) == pytest.approx(1.0, abs=0.01)


@settings(max_examples=25, deadline=None)
@given(st.floats(0.5, 1.5), st.floats(2.0, 30.0))
def test_the_ratio_is_the_scale_for_any_window(scale: float, window: float) -> None:
    a, b = _drive(T, scale), _drive(T)
    assert slamq.travel_ratio(a, b, window=window) == pytest.approx(scale, rel=1e-9)


def test_too_little_overlap_has_no_figure() -> None:
    a = _drive(np.arange(0.0, 15.0, 0.1))
    assert math.isnan(slamq.travel_ratio(a, _drive(T)))  # one window of 10 s only
    later = _drive(np.arange(200.0, 300.0, 0.1))
    assert math.isnan(slamq.travel_ratio(later, _drive(T)))  # no common time
    still = Trajectory.from_xy_yaw(T, np.zeros_like(T), np.zeros_like(T), np.zeros_like(T))
    assert math.isnan(slamq.travel_ratio(_drive(T), still))  # b does not move
    assert slamq.travel_ratio(still, _drive(T)) == 0.0


@pytest.mark.parametrize("window", [0.0, -1.0, math.nan, math.inf, "10"])
def test_a_window_that_is_not_a_positive_time_is_an_error(window: object) -> None:
    with pytest.raises(TrajectoryError, match="travel window"):
        slamq.travel_ratio(_drive(T), _drive(T), window=window)  # type: ignore[arg-type]


def _corridor_drive(t: np.ndarray, corridor_speed: float, scale: float = 1.0) -> Trajectory:
    """Straight along x at 0.5 m/s, at ``corridor_speed`` from 40 s to 80 s, all times
    ``scale``."""
    speed = np.where((t >= 40) & (t < 80), corridor_speed, 0.5)
    x = np.concatenate([[0.0], np.cumsum(speed[:-1] * np.diff(t))])
    return Trajectory.from_xy_yaw(t, scale * x, np.zeros_like(t), np.zeros_like(t))


STAMPS = np.arange(0.0, 120.0, 0.5)
#: the scans from 40 s to 80 s see walls in one direction only (ratio 0.02 < 0.1)
RATIOS = np.where((STAMPS >= 40) & (STAMPS < 80), 0.02, 0.7)


def test_along_the_corridors_a_scale_cancels_and_a_slide_does_not() -> None:
    """docs/spec.md 7d (candidate T2): a path that follows the odometry's scale error
    travels 3% more everywhere, one that slid in the corridor 10% less there only."""
    from slamq.metrics.travel import corridor_travel_ratio

    truth = _corridor_drive(T, 0.5)
    longer = _corridor_drive(T, 0.5, scale=1.03)
    slid = _corridor_drive(T, 0.45)
    assert slamq.travel_ratio(truth, longer) == pytest.approx(1 / 1.03, rel=1e-9)
    assert corridor_travel_ratio(truth, longer, STAMPS, RATIOS) == pytest.approx(1.0, rel=1e-9)
    assert corridor_travel_ratio(slid, truth, STAMPS, RATIOS) == pytest.approx(0.9, rel=1e-9)
    assert corridor_travel_ratio(slid, longer, STAMPS, RATIOS) == pytest.approx(0.9, rel=1e-9)
    # no corridor window, or no scored scan with a ratio: the whole path's ratio
    for ratios in (np.full_like(STAMPS, 0.7), np.full_like(STAMPS, np.nan)):
        assert corridor_travel_ratio(slid, truth, STAMPS, ratios) == pytest.approx(
            slamq.travel_ratio(slid, truth), rel=1e-12)
    with pytest.raises(TrajectoryError, match="stamps but"):
        corridor_travel_ratio(slid, truth, STAMPS, RATIOS[:-1])
