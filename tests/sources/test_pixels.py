"""The loader's map_saver pass in Rust (rust/src/pixels.rs) equals its numpy reference."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from slamq.sources.pixels import _map_saver_shades, _map_saver_shades_numpy


def _same(grey: np.ndarray) -> None:
    got, want = _map_saver_shades(grey), _map_saver_shades_numpy(grey)
    if want is None:
        assert got is None
        return
    assert got is not None
    assert got[0] == want[0]
    assert got[1].dtype == bool and got[1].shape == grey.shape
    assert np.array_equal(got[1], want[1])


@settings(max_examples=200, deadline=None)
@given(
    h=st.integers(1, 40), w=st.integers(1, 300),
    palette=st.lists(st.sampled_from([0, 205, 254, 255, 1, 100, 204, 206, 253]),
                     min_size=1, max_size=4, unique=True),
    seed=st.integers(0, 2**32 - 1), step=st.sampled_from([1, 2]),
)
def test_rust_shades_equal_numpy_on_random_images(
    h: int, w: int, palette: list[int], seed: int, step: int
) -> None:
    """Shades present, a stray value, row lengths around the 256-cell blocks, and strided
    (non-contiguous) views."""
    rng = np.random.default_rng(seed)
    grey = np.asarray(palette, np.uint8)[rng.integers(0, len(palette), (h, w * step))]
    _same(grey[:, ::step])


def test_rust_shades_equal_numpy_on_the_shipped_maps(test_data: Path) -> None:
    images = sorted(p for p in test_data.rglob("*") if p.suffix.lower() in (".pgm", ".png"))
    assert images, f"no images under {test_data}"
    saver = 0
    for p in images:
        grey = cv2.imread(str(p), cv2.IMREAD_GRAYSCALE)
        assert grey is not None, p
        _same(grey)
        saver += _map_saver_shades(grey) is not None
    assert saver >= 1  # some of them are map_saver images


@pytest.mark.parametrize("shape", [(0, 5), (5, 0)])
def test_rust_shades_of_an_empty_image(shape: tuple[int, int]) -> None:
    _same(np.zeros(shape, np.uint8))
