"""The pyo3 boundary: bad buffers become Python exceptions (never a panic or a crash), the
map is read without copies, and results do not depend on the thread count."""

from __future__ import annotations

import threading
from types import SimpleNamespace

import numpy as np
import pytest

import slamq
from slamq import _core


def _room(h: int = 40, w: int = 50) -> tuple[np.ndarray, np.ndarray]:
    v = np.full((h, w), 205, np.uint8)
    v[5:-5, 5:-5] = 0
    v[7:-7, 7:-7] = 254
    return v, v == 205


P = slamq.Params()


def _params(**kwargs: object) -> SimpleNamespace:
    """Parameters the Python table would refuse: the core checks them itself too."""
    return SimpleNamespace(**{**P.to_dict(), **kwargs})


def test_plain_call_returns_the_integers() -> None:
    v, u = _room()
    out = _core.evaluate(v, u, P)
    assert isinstance(out, _core.RawQuality)
    assert out.known == int((~u).sum())
    assert len(out.curve) == 256 and max(out.curve) == 1
    assert "RawQuality(known=" in repr(out)


def test_the_core_defaults_equal_the_parameter_table() -> None:
    assert _core.default_params() == P.to_dict()


@pytest.mark.parametrize(
    "values, unknown, exc, text",
    [
        (np.zeros((4, 4), np.uint8), np.zeros((4, 5), bool), ValueError, "shape"),
        (np.zeros((4, 4), np.uint16), np.zeros((4, 4), bool), TypeError, None),
        (np.zeros((4, 4), np.uint8), np.zeros((4, 4), np.uint8), TypeError, None),
        (np.zeros((4,), np.uint8), np.zeros((4,), bool), TypeError, None),
        (np.zeros((4, 8), np.uint8)[:, ::2], np.zeros((4, 4), bool), ValueError, "contiguous"),
        (np.zeros((0, 4), np.uint8), np.zeros((0, 4), bool), ValueError, "zero cells"),
        ([[1, 2]], [[True, False]], TypeError, None),
    ],
)
def test_bad_buffers_raise(values: object, unknown: object, exc: type, text: str | None) -> None:
    with pytest.raises(exc, match=text):
        _core.evaluate(values, unknown, P)


@pytest.mark.parametrize(
    "kwargs",
    [{"sweep_step": 0}, {"sweep_step": 300}, {"min_area": -1}, {"min_dot_area": -2},
     {"harris_quality": 1.5}, {"harris_quality": float("nan")},
     {"log_threshold": float("inf")}, {"harris_k": float("nan")}],
)
def test_bad_parameters_raise(kwargs: dict) -> None:
    v, u = _room()
    with pytest.raises((ValueError, OverflowError)):
        _core.evaluate(v, u, _params(**kwargs))
    with pytest.raises(slamq.ParamError):
        slamq.evaluate(slamq.OccupancyMap(v, u), **kwargs)


def test_thread_counts_and_concurrent_callers_agree() -> None:
    rng = np.random.default_rng(3)
    v = rng.integers(0, 256, (300, 257)).astype(np.uint8)
    u = rng.random((300, 257)) < 0.3
    ref = _core.evaluate(v, u, P, threads=1)
    for threads in (0, 2, 3, 7):
        assert _core.evaluate(v, u, P, threads=threads) == ref
    results: list[_core.RawQuality] = []
    workers = [threading.Thread(target=lambda: results.append(_core.evaluate(v, u, P, threads=1)))
               for _ in range(4)]
    for t in workers:
        t.start()
    for t in workers:
        t.join()
    assert results == [ref] * 4


def test_evaluate_many_matches_one_by_one() -> None:
    maps = [_room(30 + i, 40 + 2 * i) for i in range(5)]
    p = slamq.Params(sweep_step=5, canonical_resolution=0.07)
    many = _core.evaluate_many([(v, u, 0.05) for v, u in maps], p, threads=2)
    assert many == [_core.evaluate(v, u, p, resolution=0.05) for v, u in maps]
    assert many != _core.evaluate_many([(v, u, 0.01) for v, u in maps], p)  # canonical


def test_the_buffers_are_not_copied_or_changed() -> None:
    v, u = _room()
    before = (v.copy(), u.copy())
    v.setflags(write=False)
    u.setflags(write=False)  # read-only input works: the core only borrows
    _core.evaluate(v, u, P)
    assert np.array_equal(v, before[0]) and np.array_equal(u, before[1])


def test_numpy_scalars_are_accepted_as_parameters_and_threads() -> None:
    v, u = _room()
    grid = slamq.OccupancyMap(v, u)
    q = slamq.evaluate(grid, sweep_step=np.int64(5), min_area=np.int32(2),
                       harris_k=np.float32(0.04), threads=np.int64(2))
    assert q.params == slamq.Params(sweep_step=5, min_area=2, harris_k=float(np.float32(0.04)))
    assert type(q.params.sweep_step) is int and q.to_dict()["param_sweep_step"] == 5
    assert q == slamq.evaluate(grid, sweep_step=5, min_area=2, harris_k=float(np.float32(0.04)))
    for bad in (0, 1.5, "2", True):
        with pytest.raises(slamq.ParamError, match="threads"):
            slamq.evaluate(grid, threads=bad)
