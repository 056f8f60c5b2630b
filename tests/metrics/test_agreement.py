"""slamq.agreement: maps of one place as evidence about each other (docs/spec.md section 9)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import slamq
from slamq.errors import ParamError
from slamq.models import OccupancyMap
from slamq.synth.damage import degrade, floor_plan


@pytest.fixture(scope="module")
def plan() -> OccupancyMap:
    return floor_plan(5)


def test_identical_maps_confirm_each_other_fully(plan: OccupancyMap) -> None:
    a = slamq.agreement({"a": plan, "b": plan, "c": plan}, align="origin")
    assert a.support == {"a": 1.0, "b": 1.0, "c": 1.0}
    assert a.completeness == {"a": 1.0, "b": 1.0, "c": 1.0}
    assert a.majority and a.notes == []
    assert np.isnan(np.diag(a.consistency)).all()
    assert np.allclose(a.consistency, a.consistency.T, equal_nan=True)


@pytest.mark.parametrize(("kind", "severity", "margin"), [
    ("doubling", 0.8, 0.05), ("drift", 8.0, 0.05), ("specks", 0.02, 0.02)])
def test_a_damaged_map_is_the_least_supported(plan: OccupancyMap, kind: str,
                                              severity: float, margin: float) -> None:
    bad = degrade(plan, kind, severity, seed=1)
    a = slamq.agreement({"a": plan, "b": plan, "bad": bad}, align="icp")
    assert a.support["bad"] < a.support["a"] - margin
    assert a.support["a"] == a.support["b"]


def test_a_turned_map_is_not_damage(plan: OccupancyMap) -> None:
    turned = degrade(plan, "rotation", 10.0)  # the whole map turned: only its frame differs
    a = slamq.agreement({"a": plan, "b": plan, "t": turned}, align="icp")
    assert a.support["t"] > 0.95


def test_a_partial_map_is_supported_but_incomplete(plan: OccupancyMap) -> None:
    half = plan.values.copy()
    unknown = plan.unknown.copy()
    w = half.shape[1] // 2
    half[:, w:] = 205
    unknown[:, w:] = True
    part = OccupancyMap(half, unknown, plan.resolution, plan.origin, source="half")
    a = slamq.agreement({"a": plan, "b": plan, "half": part}, align="origin")
    assert a.support["half"] > 0.95  # what it has is right...
    assert a.completeness["half"] < 0.7 < a.completeness["a"]  # ...but it saw less


def test_maps_that_all_disagree_have_no_majority(plan: OccupancyMap) -> None:
    maps = {k: degrade(plan, "doubling", 1.6, seed=s) for k, s in (("x", 1), ("y", 2),
                                                                     ("z", 3))}
    maps = {k: degrade(m, "specks", 0.05, seed=9) for k, m in maps.items()}
    a = slamq.agreement(maps, align="origin", min_support=0.9)
    assert not a.majority
    assert any("disagree among themselves" in n for n in a.notes)


def test_arrays_and_paths_are_read(tmp_path) -> None:
    img = np.full((30, 30), 254, np.uint8)
    img[5, 5:25] = 0
    img[5:25, 5] = 0
    from PIL import Image

    Image.fromarray(img).save(tmp_path / "m.pgm")
    a = slamq.agreement([img, str(tmp_path / "m.pgm")], align="origin")
    assert a.names == ["0", "1"] and a.support["0"] == 1.0


def test_bad_arguments_are_refused(plan: OccupancyMap) -> None:
    with pytest.raises(ParamError, match="at least 2 maps"):
        slamq.agreement([plan])
    with pytest.raises(ParamError, match="align must be one of"):
        slamq.agreement([plan, plan], align="nope")
    with pytest.raises(ParamError, match="min_support"):
        slamq.agreement([plan, plan], min_support=2)


def test_a_map_without_walls_has_no_support_figure(plan: OccupancyMap) -> None:
    blank = OccupancyMap(np.full(plan.shape, 254, np.uint8), np.zeros(plan.shape, bool),
                         plan.resolution, plan.origin, source="blank")
    a = slamq.agreement({"a": plan, "b": plan, "blank": blank}, align="origin")
    assert a.support["a"] == 1.0
    assert math.isnan(a.support["blank"]) or a.support["blank"] < 0.5


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_wall_missing_in_one_map_is_flagged_where_it_is(seed: int) -> None:
    from slamq.metrics.agreement import missing_walls

    plan = floor_plan(seed)
    gap = degrade(plan, "gap", 2.0, seed=seed)
    maps = {"a": plan, "b": degrade(plan, "specks", 0.001, seed=seed), "gap": gap}
    flags = missing_walls(slamq.agreement(maps, align="icp"), maps)
    assert flags["a"] == [] and flags["b"] == []
    (d,) = flags["gap"]
    assert d.kind == "missing_walls" and d.score >= 1.0
    # the box lies on the walls the damage removed
    removed = (plan.values < 128) & (gap.values[: plan.shape[0], : plan.shape[1]] >= 128)
    c0, r0, c1, r1 = d.bbox
    assert removed[r0:r1, c0:c1].sum() >= 0.8 * removed.sum()


def test_clean_copies_have_no_missing_walls(plan: OccupancyMap) -> None:
    from slamq.metrics.agreement import missing_walls

    maps = {"a": plan, "b": degrade(plan, "drift", 0.5), "c": degrade(plan, "specks", 0.002)}
    assert all(v == [] for v in missing_walls(slamq.agreement(maps, align="icp"), maps).values())


def test_the_agreeing_group_is_the_largest_set_that_agrees_pairwise() -> None:
    from slamq.metrics.agreement import EXACT_GROUP_MAPS, agreeing_group

    nan = math.nan
    c = np.array([[nan, 0.99, 0.2, 0.6, 0.1],
                  [0.99, nan, 0.1, 0.7, 0.1],
                  [0.2, 0.1, nan, 0.3, 0.9],
                  [0.6, 0.7, 0.3, nan, 0.2],
                  [0.1, 0.1, 0.9, 0.2, nan]])
    assert agreeing_group(c, 0.6) == [0, 1, 3]       # size beats consistency
    assert agreeing_group(c, 0.8) == [0, 1]          # of two pairs, the more consistent
    assert agreeing_group(c, 0.995) == []
    assert agreeing_group(np.full((3, 3), nan), 0.6) == []
    # greedy beyond the exact size finds a planted clique among random pairs
    rng = np.random.default_rng(0)
    n = EXACT_GROUP_MAPS + 4
    big = rng.uniform(0.0, 0.5, (n, n))
    big = (big + big.T) / 2
    members = [1, 5, 8, 13, 19]
    for i in members:
        for j in members:
            big[i, j] = 0.95
    np.fill_diagonal(big, nan)
    assert agreeing_group(big, 0.6) == members


def test_two_good_maps_among_broken_ones_form_the_group() -> None:
    """Issue 41, item 1: three broken maps drag every median support down; the two maps
    that agree with each other are the group."""
    plan = floor_plan(3)
    maps = {"good1": plan, "good2": plan}
    for k, (kind, severity) in enumerate((("drift", 8.0), ("kinks", 30.0),
                                          ("rotation", 20.0))):
        maps[f"broken{k}"] = degrade(plan, kind, severity, seed=k)
    a = slamq.agreement(maps, align="origin")
    assert a.group == ["good1", "good2"]
    assert not a.majority
