"""Conformance (SPEC section 5): the Rust core equals :mod:`slamq.metrics.reference` exactly.

Integers (counts, corners, the whole enclosed-area curve, the unknown value reaching its
maximum) must be identical and ratios equal to 1e-12 relative
(:meth:`slamq.MapQuality.differences`), on the shipped fixtures (tests/data), on every
loadable map of the ../shared/data corpus (one test per map; unloadable maps are skipped
with the loader's reason), and on hypothesis maps (tests/strategies.py).

The reference labels each map once per sweep value, so the corpus part takes minutes
(about 3 on one core of the development machine); it is the price of checking every map.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import SHARED_DATA, TEST_DATA
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from strategies import occupancy_maps

import slamq
from slamq import MapError, OccupancyMap, Params
from slamq.metrics import reference
from slamq.sources import discover_maps

pytest.importorskip("slamq._core", reason="the Rust core is not built (maturin develop)")



def _discover(root: Path) -> list[Any]:
    """One pytest param per map under ``root`` (ids relative to it); problems become skips."""
    if not root.is_dir():
        return [pytest.param(None, id="absent")]
    found, problems = discover_maps([root])
    params = [pytest.param(Path(p), id=str(Path(p).relative_to(root))) for p in found]
    params += [pytest.param((path, reason), id=f"problem:{path}") for path, reason in problems]
    return params or [pytest.param(None, id="empty")]


def assert_conforms(grid: OccupancyMap, **params: Any) -> slamq.MapQuality:
    """Rust vs reference on one map, with the whole curve; returns the reference result."""
    expected = reference.evaluate(grid, curve=True, **params)
    got = slamq.evaluate(grid, curve=True, **params)
    diffs = got.differences(expected)
    if diffs:
        values = np.array2string(grid.values, threshold=400, separator=", ")
        unknown = np.array2string(grid.unknown, threshold=400, separator=", ")
        pytest.fail(
            f"{grid.source} {grid.shape} params={params}: Rust != reference: "
            + "; ".join(diffs)
            + (f"\nvalues={values}\nunknown={unknown}" if grid.values.size <= 400 else "")
        )
    return expected


def _load_or_skip(item: Any) -> OccupancyMap:
    if item is None:
        pytest.skip("no maps here")
    if isinstance(item, tuple):
        path, reason = item
        pytest.skip(f"{path}: {reason}")
    try:
        return slamq.load_map(item)
    except MapError as exc:
        pytest.skip(f"unloadable, {exc}")


@pytest.mark.filterwarnings("ignore::UserWarning")
@pytest.mark.parametrize("item", _discover(TEST_DATA))
def test_fixture_maps(item: Any, test_data: Path) -> None:
    assert_conforms(_load_or_skip(item))


@pytest.mark.filterwarnings("ignore::UserWarning")
@pytest.mark.parametrize("item", _discover(SHARED_DATA / "maps"))
def test_corpus_maps(item: Any, shared_data: Path) -> None:
    assert_conforms(_load_or_skip(item))


def test_corpus_map_with_other_parameters(shared_data: Path) -> None:
    path = shared_data / "maps" / "utexas_gdc_large" / "3" / "3.yaml"
    if not path.exists():
        pytest.skip(f"{path} not in the corpus")
    assert_conforms(
        slamq.load_map(path), log_threshold=0.05, min_dot_area=2, harris_k=0.06,
        harris_quality=0.05, sweep_step=3, min_area=4,
    )


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(occupancy_maps(max_side=200))
def test_hypothesis_maps(grid: OccupancyMap) -> None:
    assert_conforms(grid)


params_strategy = st.builds(
    Params,
    log_threshold=st.sampled_from([0.0, 0.01, 0.05, 0.1, 0.3, 1.0]),
    min_dot_area=st.integers(0, 12),
    harris_k=st.sampled_from([0.0, 0.04, 0.06, 0.15, 0.25]),
    harris_quality=st.sampled_from([0.0, 0.001, 0.01, 0.1, 0.5, 1.0]),
    sweep_step=st.sampled_from([1, 2, 7, 17, 85, 255, 256]),
    min_area=st.integers(0, 30),
)


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(occupancy_maps(max_side=80), params_strategy)
def test_hypothesis_maps_any_parameters(grid: OccupancyMap, params: Params) -> None:
    assert_conforms(grid, **params.to_dict())


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(occupancy_maps(min_side=30, max_side=200))
def test_thread_count_does_not_matter(grid: OccupancyMap) -> None:
    one = slamq.evaluate(grid, curve=True, threads=1)
    two = slamq.evaluate(grid, curve=True, threads=2)
    default = slamq.evaluate(grid, curve=True)
    assert one.differences(two) == [] and one.differences(default) == []


def _broken_map(seed: int, h: int, w: int, copies: int, noise: float) -> OccupancyMap:
    """A map like awabot hector_odom: rooms drawn ``copies`` times with drift (superposed,
    shifted and sheared copies of the same walls), free space sprinkled with unknown and
    occupied specks, so that every row has dozens of short runs."""
    rng = np.random.default_rng(seed)
    values = np.full((h, w), 205, np.uint8)
    unknown = np.ones((h, w), bool)
    rooms = [(int(rng.integers(0, h // 2)), int(rng.integers(0, w // 2)),
              int(rng.integers(8, h // 2 + 9)), int(rng.integers(8, w // 2 + 9)))
             for _ in range(int(rng.integers(2, 7)))]
    for k in range(copies):
        dr, dc = int(rng.integers(-6, 7)), int(rng.integers(-6, 7))
        shear = rng.uniform(-0.05, 0.05)
        for r0, c0, hh, ww in rooms:
            rr0, cc0 = r0 + dr + k, c0 + dc
            rows = slice(max(rr0, 0), max(min(rr0 + hh, h), 0))
            cols = slice(max(cc0, 0), max(min(cc0 + ww, w), 0))
            unknown[rows, cols] = False
            block = values[rows, cols]
            block[block == 205] = 254
            for r in range(rows.start, rows.stop):
                off = int(round(shear * (r - rows.start)))
                for c in (cc0 + off, cc0 + ww - 1 + off):
                    if 0 <= c < w:
                        values[r, c] = 0
            for r in (rows.start, rows.stop - 1):
                if rows.start < rows.stop:
                    values[r, cols] = 0
    specks = rng.random((h, w)) < noise
    unknown[specks & (rng.random((h, w)) < 0.5)] = True
    values[specks & ~unknown] = 0
    values[unknown] = 205
    return OccupancyMap(values, unknown, source=f"<broken map {seed} {h}x{w} x{copies}>")


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2**32 - 1), st.integers(65, 260), st.integers(20, 200),
       st.integers(1, 4), st.sampled_from([0.0, 0.01, 0.05, 0.2]))
def test_broken_maps_with_superposed_copies(seed: int, h: int, w: int, copies: int,
                                            noise: float) -> None:
    # many short runs, dots and corners across several row bands (64 rows): the packed run
    # extraction, the label-free counts, the dot removal by runs and the hot-key histogram
    grid = _broken_map(seed, h, w, copies, noise)
    expected = assert_conforms(grid)
    two = slamq.evaluate(grid, curve=True, threads=2)
    assert two.differences(expected) == []
