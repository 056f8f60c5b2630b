"""A bounded fuzz job over the parsers of untrusted files: map YAML, PNM images, Cartographer
pbstreams (trajectories and submap maps) and text trajectories. Each test mutates valid
inputs built here (byte flips, insertions, deletions, truncations, random fields) and
asserts that the reader either succeeds or raises its own slamq error (MapError,
TrajectoryError), never anything else. Hypothesis bounds each one by ``max_examples``; a
run takes about ten seconds."""

from __future__ import annotations

import tempfile
import warnings
from pathlib import Path

import numpy as np
from _pbencode import FREE, OCC, f_varint, full_stream, graph, grid2d, stream, submap
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import slamq
from slamq.errors import MapError, MapWarning, TrajectoryError

FUZZ = settings(max_examples=250, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


@st.composite
def mutated(draw: st.DrawFn, seed: bytes) -> bytes:
    """``seed`` with a few random edits."""
    data = bytearray(seed)
    for _ in range(draw(st.integers(1, 6))):
        op = draw(st.sampled_from(["flip", "insert", "delete", "truncate", "digits"]))
        at = draw(st.integers(0, max(len(data) - 1, 0)))
        if op == "flip" and data:
            data[at] = draw(st.integers(0, 255))
        elif op == "insert":
            data[at:at] = draw(st.binary(min_size=1, max_size=16))
        elif op == "delete" and data:
            del data[at:at + draw(st.integers(1, 16))]
        elif op == "truncate":
            del data[at:]
        elif op == "digits":  # long numbers where numbers are parsed
            data[at:at] = draw(st.text("0123456789-+.e", min_size=1, max_size=40)).encode()
    return bytes(data)


def _load_map_bytes(name: str, data: bytes, extra: dict[str, bytes] | None = None) -> None:
    with tempfile.TemporaryDirectory() as d:
        for n, b in (extra or {}).items():
            (Path(d) / n).write_bytes(b)
        p = Path(d) / name
        p.write_bytes(data)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", MapWarning)
                slamq.load_map(p)
        except MapError as exc:
            assert str(exc).startswith(str(p)) or str(p.parent) in str(exc), exc
            assert "\n" not in str(exc).strip()


_IMG = np.full((6, 7), 254, np.uint8)
_IMG[2:4, 1:5] = 0
_P5 = b"P5\n# CREATOR: map_saver.cpp 0.050 m/pix\n7 6\n255\n" + _IMG.tobytes()
_P2 = b"P2\n7 6\n255\n" + b"\n".join(b" ".join(b"%d" % v for v in row) for row in _IMG) + b"\n"
_YAML = (b"image: m.pgm\nresolution: 0.050000\norigin: [-10.0, -10.0, 0.0]\nnegate: 0\n"
         b"occupied_thresh: 0.65\nfree_thresh: 0.196\nmode: trinary\n")


@FUZZ
@given(data=st.one_of(mutated(_P5), mutated(_P2)))
def test_fuzz_pnm(data: bytes) -> None:
    _load_map_bytes("m.pgm", data)


@FUZZ
@given(data=mutated(_YAML))
def test_fuzz_map_yaml_bytes(data: bytes) -> None:
    _load_map_bytes("m.yaml", data, {"m.pgm": _P5})


_SCALARS = st.one_of(st.none(), st.booleans(), st.integers(-(2**70), 2**70),
                     st.floats(allow_nan=True, allow_infinity=True), st.text(max_size=20))


@FUZZ
@given(fields=st.dictionaries(
    st.sampled_from(["image", "resolution", "origin", "negate", "occupied_thresh",
                     "free_thresh", "mode", "unknown"]),
    st.one_of(_SCALARS, st.lists(_SCALARS, max_size=4),
              st.dictionaries(st.text(max_size=5), _SCALARS, max_size=3)),
))
def test_fuzz_map_yaml_fields(fields: dict) -> None:
    import yaml

    doc = {"image": "m.pgm", "resolution": 0.05, **fields}
    _load_map_bytes("m.yaml", yaml.safe_dump(doc).encode(), {"m.pgm": _P5})


def _load_trajectory_bytes(name: str, data: bytes) -> None:
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / name
        p.write_bytes(data)
        try:
            slamq.load_trajectory(p)
        except TrajectoryError as exc:
            assert str(p) in str(exc), exc


_TUM = b"".join(b"%.6f %.3f %.3f 0 0 0 %.6f %.6f\n" % (1e9 + i, i * 0.1, -i * 0.05,
                                                     np.sin(i / 10), np.cos(i / 10))
                for i in range(12))
_KITTI = b"".join(b"1 0 0 %.2f 0 1 0 %.2f 0 0 1 0\n" % (i * 0.1, i * 0.2) for i in range(12))


@FUZZ
@given(data=st.one_of(mutated(_TUM), mutated(b"# timestamp x y z qx qy qz qw\n" + _TUM)))
def test_fuzz_tum_trajectory(data: bytes) -> None:
    _load_trajectory_bytes("t.tum", data)


@FUZZ
@given(data=mutated(_KITTI))
def test_fuzz_kitti_trajectory(data: bytes) -> None:
    _load_trajectory_bytes("t.kitti", data)


_PBSTREAM = full_stream()  # the independent encoder of tests/_pbencode.py


@FUZZ
@given(data=st.data())
def test_fuzz_pbstream(data: st.DataObject) -> None:
    _load_trajectory_bytes("m.pbstream", data.draw(mutated(_PBSTREAM)))


def _submap_stream() -> bytes:
    cells = np.full((6, 5), FREE, np.int64)
    cells[3, 1] = OCC
    return stream(f_varint(1, 2), graph({0: (0, 0, 0)}),
                  submap(0, 0, (0, 0, 0), grid2d(cells, (2.0, 1.0), (0, 0, 4, 5))))


_SUBMAPS = _submap_stream()


@FUZZ
@given(data=mutated(_SUBMAPS))
def test_fuzz_pbstream_map(data: bytes) -> None:
    _load_map_bytes("m.pbstream", data)
