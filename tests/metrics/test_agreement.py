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


def test_one_programs_reruns_are_no_group_two_programs_that_agree_are() -> None:
    """A deterministic program run three times draws one broken map three times: by maps
    alone those copies are the largest agreeing set, but they are one program's; with
    ``owners`` the group is the two programs whose maps agree (docs/validity.md, "An
    agreeing group of one program's runs")."""
    from slamq.metrics.agreement import agreeing_group

    plan = floor_plan(3)
    kinked = degrade(plan, "kinks", 30.0, seed=0)
    maps = {"a": plan, "b": degrade(plan, "drift", 0.5, seed=1),
            "c#1": kinked, "c#2": kinked, "c#3": kinked}
    owners = {"a": "a", "b": "b", "c#1": "c", "c#2": "c", "c#3": "c"}
    a = slamq.agreement(maps, align="origin", owners=owners)
    assert a.consistency[0, 1] >= 0.6 and a.consistency[2, 3] == pytest.approx(1.0)
    assert a.group == ["a", "b"]
    # by maps alone (no owners) the three copies win, as the group was chosen before
    assert [a.names[i] for i in agreeing_group(a.consistency, 0.6)] == ["c#1", "c#2", "c#3"]
    # and one program's copies alone are no group at all
    alone = slamq.agreement({k: maps[k] for k in ("c#1", "c#2", "c#3")}, align="origin",
                            owners=owners)
    assert alone.group == []


def test_a_map_of_one_room_confirms_no_broken_map() -> None:
    """A map that knows one room (under 2% of the building) agrees with any map there; it
    forms no group with a broken map (docs/validity.md, "A minimum overlap")."""
    from slamq.metrics.agreement import GROUP_MIN_OVERLAP, agreeing_group

    plan = floor_plan(3)
    h, w = plan.values.shape
    room = np.zeros((h, w), bool)
    room[:h // 6, :w // 6] = True
    tiny = OccupancyMap(np.where(room, plan.values, 205).astype(np.uint8),
                        plan.unknown | ~room, plan.resolution, plan.origin)
    maps = {"tiny": tiny, "kinked": degrade(plan, "kinks", 30.0, seed=0),
            "drifted": degrade(plan, "drift", 8.0, seed=5)}
    a = slamq.agreement(maps, align="origin")
    assert a.completeness["tiny"] < GROUP_MIN_OVERLAP
    assert a.consistency[0, 1] >= 0.6 and a.consistency[0, 2] >= 0.6  # it agrees there
    assert a.consistency[1, 2] < 0.6                                  # the others do not
    assert "tiny" in [a.names[i] for i in agreeing_group(a.consistency, 0.6)]
    assert a.group == []


def _pair_on_the_whole_grid(est: OccupancyMap, ref: OccupancyMap, align: str
                            ) -> tuple[float, float, float, np.ndarray]:
    """A pair's figures as docs/spec.md section 9 defines them, on the whole grid (what
    slamq.metrics.agreement counts within the box of the fixed map's known cells)."""
    import cv2

    from slamq.metrics.compare import compare

    c = compare(est, ref, align=align, cells=True, min_fit_precision=0.0)
    f = c.cells
    grow = max(1, math.ceil(c.tolerance / c.resolution))
    k = np.ones((2 * grow + 1, 2 * grow + 1), np.uint8)

    def grown(m: np.ndarray) -> np.ndarray:
        return cv2.dilate(m.astype(np.uint8), k) != 0

    e, g = (f & 1) != 0, (f & 2) != 0
    ref_cells, est_known = (f & 34) != 0, (f & 17) != 0
    e_in, g_in = e & grown(ref_cells), g & grown(est_known)

    def share(n: np.ndarray, d: np.ndarray) -> float:
        return np.count_nonzero(n) / np.count_nonzero(d) if d.any() else math.nan

    return (share(e_in & ((f & 4) != 0), e_in), share(g_in & ((f & 8) != 0), g_in),
            share(ref_cells & est_known, ref_cells), e & ((f & 4) == 0) & ((f & 32) != 0))


def test_a_pair_read_within_the_known_box_equals_the_whole_grid(plan: OccupancyMap) -> None:
    from slamq.metrics.agreement import _pair

    # a part of the map in a corner of a larger grid, and maps with walls where the other
    # map knows nothing
    h, w = plan.shape
    big = np.full((h + 60, w + 90), 205, np.uint8)
    unknown = np.ones(big.shape, bool)
    big[40:40 + h // 2, 70:70 + w // 2] = plan.values[:h // 2, :w // 2]
    unknown[40:40 + h // 2, 70:70 + w // 2] = plan.unknown[:h // 2, :w // 2]
    res = plan.resolution
    corner = OccupancyMap(big, unknown, res, (plan.origin[0] - 70 * res,
                                              plan.origin[1] - (60 - 40) * res, 0.0))
    maps = [plan, corner, degrade(plan, "doubling", 0.8, seed=2),
            degrade(plan, "rotation", 10.0)]
    for est in maps:
        for ref in maps:
            for align in ("icp", "origin"):
                got = _pair(est, ref, align, None, 1)
                want = _pair_on_the_whole_grid(est, ref, align)
                assert all(x == y or (math.isnan(x) and math.isnan(y)) for x, y in
                           zip((got.support, got.recall, got.covers), want[:3]))
                assert np.array_equal(got.vote(None) != 0, want[3])


def test_the_figures_do_not_depend_on_threads_or_a_pool(plan: OccupancyMap) -> None:
    from concurrent.futures import ThreadPoolExecutor

    none = np.zeros(plan.shape, bool)
    moved = OccupancyMap(plan.values, none, plan.resolution, (3.0, -1.0, 0.7))
    maps = {"a": plan, "b": degrade(plan, "specks", 0.01, seed=3),
            "c": degrade(plan, "doubling", 0.8, seed=1), "m": moved}
    one = slamq.agreement(maps, threads=1)
    with ThreadPoolExecutor(3) as pool:
        others = [slamq.agreement(maps, threads=2), slamq.agreement(maps, pool=pool)]
    for a in others:
        assert np.array_equal(a.consistency, one.consistency, equal_nan=True)
        assert (a.support, a.completeness, a.placed, a.notes, a.group) == (
            one.support, one.completeness, one.placed, one.notes, one.group)
        assert a.missing.keys() == one.missing.keys()
        assert all(np.array_equal(a.missing[k], one.missing[k]) for k in one.missing)
    assert one.placed["m"] and one.support["m"] > 0.9  # placed by the registration
