"""slamq.synth: synthetic map series with known severity — the plan comes back unchanged
at severity 0, the damage grows with the severity, results are reproducible (the study of
the metrics on them: studies/tests)."""

from __future__ import annotations

import numpy as np
import pytest

import slamq
from slamq import synth

SMALL = {"rooms": (2, 2)}


@pytest.fixture(scope="module")
def plan() -> slamq.OccupancyMap:
    return synth.floor_plan(3, **SMALL)


@pytest.mark.parametrize("kind", list(synth.DEGRADATIONS))
def test_severity_zero_gives_the_plan_back_and_its_scores(plan, kind) -> None:
    m = synth.degrade(plan, kind, 0)
    assert m.shape == plan.shape and m.origin == plan.origin
    assert np.array_equal(m.values, plan.values) and np.array_equal(m.unknown, plan.unknown)
    assert slamq.evaluate(m).differences(slamq.evaluate(plan)) == []


def test_the_plan_is_a_building_with_rooms_and_doors(plan) -> None:
    import cv2

    free = (~plan.unknown & (plan.values > 128)).astype(np.uint8)
    n, _ = cv2.connectedComponents(free, connectivity=4)
    assert n - 1 == 1  # every room reachable: one free region (doors)
    walls = (~plan.unknown & (plan.values == 0)).astype(np.uint8)
    assert walls.sum() > 0 and plan.unknown[0, 0] and not plan.unknown[plan.shape[0] // 2,
                                                                        plan.shape[1] // 2]


def test_the_same_seed_gives_the_same_maps_and_another_seed_others(plan) -> None:
    a = synth.degrade(plan, "specks", 0.01, seed=1)
    assert np.array_equal(a.values, synth.degrade(plan, "specks", 0.01, seed=1).values)
    assert not np.array_equal(a.values, synth.degrade(plan, "specks", 0.01, seed=2).values)
    assert np.array_equal(synth.floor_plan(5).values, synth.floor_plan(5).values)
    assert not np.array_equal(synth.floor_plan(5).values, synth.floor_plan(6).values)


@pytest.mark.parametrize("kind", ["drift", "doubling"])
def test_more_damage_agrees_less_with_the_plan(plan, kind) -> None:
    f1 = [slamq.compare(m, plan, align="search").f1
          for _, m in synth.series(plan, kind, [0, 2, 8] if kind == "drift" else
                                   [0, 0.2, 0.8])]
    assert f1[0] == 1.0 and f1[0] > f1[1] > f1[2]


def test_a_rotation_keeps_the_map_but_raises_corners_on_a_real_map(test_data) -> None:
    real = slamq.load_map(test_data / "slam_comparison_tools" / "test_results" / "office"
                          / "gmapping_map.yaml")
    base = slamq.evaluate(real).corners
    rotated = synth.degrade(real, "rotation", 5)
    assert slamq.compare(rotated, real, align="search").f1 > 0.99  # the same map
    q = slamq.evaluate(rotated)
    assert q.corners > 1.3 * base  # the known weakness: corners rise with rotation
    assert q.occupied_fraction == pytest.approx(slamq.evaluate(real).occupied_fraction,
                                                rel=0.05)  # walls keep their thickness


def test_parameters_are_checked(plan) -> None:
    with pytest.raises(slamq.ParamError, match="kind"):
        synth.degrade(plan, "melt", 1)
    with pytest.raises(slamq.ParamError, match="severity"):
        synth.degrade(plan, "rotation", -1)
    with pytest.raises(slamq.ParamError, match="rooms"):
        synth.floor_plan(rooms=(1, 1))
