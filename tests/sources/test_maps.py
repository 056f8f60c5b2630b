"""The map loader (docs/spec.md section 1): modes, negate, colour, the 205 rule, grids, errors."""

from __future__ import annotations

import contextlib
import os
import signal
import struct
import time
import tracemalloc
import warnings
import zlib
from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import slamq
from slamq.errors import MapError, MapWarning, ParamError
from slamq.models import OccupancyMap
from slamq.sources import from_occupancy_grid, load_map

# ------------------------------------------------------------------------------ helpers

ALL_VALUES = np.arange(256, dtype=np.uint8).reshape(16, 16)


def write_pgm(path: Path, img: np.ndarray, comment: str | None = None, maxval: int = 255) -> Path:
    h, w = img.shape
    head = b"P5\n"
    if comment is not None:
        head += b"# " + comment.encode() + b"\n"
    head += f"{w} {h}\n{maxval}\n".encode()
    path.write_bytes(head + np.ascontiguousarray(img, dtype=np.uint8).tobytes())
    return path


def write_png(path: Path, img: np.ndarray) -> Path:
    ok, buf = cv2.imencode(".png", img)
    assert ok
    path.write_bytes(buf.tobytes())
    return path


def write_yaml(path: Path, image: str, **fields: object) -> Path:
    lines = [f"image: {image}"]
    fields.setdefault("resolution", 0.05)
    fields.setdefault("origin", "[-1.5, 2.0, 0.25]")
    for k, v in fields.items():
        if v is not None:
            lines.append(f"{k}: {v}")
    path.write_text("\n".join(lines) + "\n")
    return path


def load_quiet(source, **kw) -> OccupancyMap:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MapWarning)
        return load_map(source, **kw)


def load_no_warning(source, **kw) -> OccupancyMap:
    with warnings.catch_warnings():
        warnings.simplefilter("error", MapWarning)
        return load_map(source, **kw)


def raises_named(path: object, *reason: str):
    """Context manager: MapError whose message starts with ``path`` and names the reason."""

    class _Ctx:
        def __enter__(self):
            self._cm = pytest.raises(MapError)
            self.info = self._cm.__enter__()
            return self.info

        def __exit__(self, *exc):
            handled = self._cm.__exit__(*exc)
            msg = str(self.info.value)
            assert msg.startswith(f"{path}:"), msg
            for r in reason:
                assert r.lower() in msg.lower(), (r, msg)
            assert "\n" not in msg, msg
            return handled

    return _Ctx()


# --------------------------------------------------------------------- trinary / scale


def test_trinary_default_thresholds_every_pixel_value(tmp_path):
    # p = (255 - v) / 255; defaults 0.196 <= p <= 0.65  <=>  90 <= v <= 205.
    write_pgm(tmp_path / "m.pgm", ALL_VALUES)
    m = load_no_warning(write_yaml(tmp_path / "m.yaml", "m.pgm"))
    expected = (ALL_VALUES >= 90) & (ALL_VALUES <= 205)
    assert np.array_equal(m.unknown, expected)
    assert np.array_equal(m.values, ALL_VALUES)
    assert m.values.dtype == np.uint8 and m.unknown.dtype == bool
    assert m.resolution == 0.05 and m.origin == (-1.5, 2.0, 0.25)
    assert m.meta["mode"] == "trinary" and m.meta["negate"] is False
    assert m.meta["occupied_thresh"] == 0.65 and m.meta["free_thresh"] == 0.196
    assert m.meta["unknown_rule"].startswith("thresholds")
    assert m.meta["image"] == str(tmp_path / "m.pgm")
    assert m.source == str(tmp_path / "m.yaml")


def test_thresholds_are_inclusive_and_use_the_spec_formula(tmp_path):
    # occupied_thresh = 100/255 exactly as float64: v = 155 gives p == occ -> unknown.
    write_pgm(tmp_path / "m.pgm", ALL_VALUES)
    occ = 100 / 255
    free = 20 / 255
    m = load_no_warning(write_yaml(tmp_path / "m.yaml", "m.pgm", occupied_thresh=repr(occ),
                                   free_thresh=repr(free)))
    assert np.array_equal(m.unknown, (ALL_VALUES >= 155) & (ALL_VALUES <= 235))


def test_negate_flips_the_pixel(tmp_path):
    write_pgm(tmp_path / "m.pgm", ALL_VALUES)
    m = load_no_warning(write_yaml(tmp_path / "m.yaml", "m.pgm", negate=1))
    assert np.array_equal(m.values, 255 - ALL_VALUES)
    # unknown iff 90 <= 255 - x <= 205  <=>  50 <= x <= 165
    assert np.array_equal(m.unknown, (ALL_VALUES >= 50) & (ALL_VALUES <= 165))
    assert m.meta["negate"] is True
    # `negate: true` is the same
    m2 = load_no_warning(write_yaml(tmp_path / "b.yaml", "m.pgm", negate="true"))
    assert np.array_equal(m2.unknown, m.unknown)


def test_scale_mode_grey_equals_trinary_and_alpha_makes_unknown(tmp_path):
    write_pgm(tmp_path / "m.pgm", ALL_VALUES)
    tri = load_no_warning(write_yaml(tmp_path / "t.yaml", "m.pgm"))
    sc = load_no_warning(write_yaml(tmp_path / "s.yaml", "m.pgm", mode="scale"))
    assert sc.meta["mode"] == "scale"
    assert np.array_equal(sc.unknown, tri.unknown)
    # RGBA: alpha < 255 is unknown in scale mode only
    rgba = np.zeros((2, 3, 4), np.uint8)
    rgba[..., :3] = 254
    rgba[..., 3] = 255
    rgba[0, 1, 3] = 254
    rgba[1, 2, 3] = 0
    write_png(tmp_path / "a.png", rgba)
    sc = load_no_warning(write_yaml(tmp_path / "sa.yaml", "a.png", mode="scale"))
    assert sc.unknown.tolist() == [[False, True, False], [False, False, True]]
    tri = load_no_warning(write_yaml(tmp_path / "ta.yaml", "a.png"))
    assert not tri.unknown.any()
    assert sc.meta["channels"] == 4


def test_rgb_and_rgba_use_the_rounded_mean_of_colour_channels(tmp_path):
    rng = np.random.default_rng(7)
    rgb = rng.integers(0, 256, size=(9, 11, 3), dtype=np.uint8)
    rgb[0, 0] = (1, 2, 2)        # 5/3 -> 2
    rgb[0, 1] = (0, 0, 1)        # 1/3 -> 0
    rgb[0, 2] = (255, 255, 254)  # 254.67 -> 255
    expected = np.rint(rgb.astype(np.float64).mean(axis=2)).astype(np.uint8)
    assert expected[0, :3].tolist() == [2, 0, 255]
    with pytest.warns(MapWarning, match="rgb.png: has colour pixels, like a screenshot"):
        m = load_map(write_png(tmp_path / "rgb.png", rgb))
    assert np.array_equal(m.values, expected)
    assert m.meta["channels"] == 3
    # RGBA: alpha is not a colour channel
    rgba = np.dstack([rgb, np.full(rgb.shape[:2], 17, np.uint8)])
    with pytest.warns(MapWarning, match="rgba.png: has colour pixels"):
        m4 = load_map(write_png(tmp_path / "rgba.png", rgba))
    assert np.array_equal(m4.values, expected)
    assert np.array_equal(m4.unknown, (expected >= 90) & (expected <= 205))
    # numpy arrays: the same rule
    assert np.array_equal(load_no_warning(rgb).values, expected)
    assert np.array_equal(load_no_warning(rgba).values, expected)
    # a binary PPM (P6) decodes through our own parser to the same grey
    ppm = tmp_path / "c.ppm"
    ppm.write_bytes(b"P6\n11 9\n255\n" + rgb.tobytes())
    with pytest.warns(MapWarning, match="c.ppm: has colour pixels"):
        assert np.array_equal(load_map(ppm).values, expected)


# ------------------------------------------------------------------------ raw mode


def test_raw_mode_values_half_to_even(tmp_path):
    g = np.array([[0, 100, 50, 30], [70, 90, 10, 101], [254, 255, 200, 1]], np.uint8)
    write_pgm(tmp_path / "r.pgm", g)
    m = load_no_warning(write_yaml(tmp_path / "r.yaml", "r.pgm", mode="raw"))
    # v = rint(255 * (100 - g) / 100): 50 -> 127.5 -> 128; 30 -> 178.5 -> 178; 70 -> 76.5 -> 76
    assert m.unknown.tolist() == [[False] * 4, [False, False, False, True], [True, True, True,
                                                                            False]]
    known = m.values[~m.unknown].tolist()
    assert known == [255, 0, 128, 178, 76, 26, 230, 252]
    assert m.meta["mode"] == "raw"


def test_raw_mode_with_negate_reads_255_minus_pixel(tmp_path):
    g = np.array([[255, 155, 0]], np.uint8)  # negated: 0, 100, 255
    write_pgm(tmp_path / "r.pgm", g)
    m = load_no_warning(write_yaml(tmp_path / "r.yaml", "r.pgm", mode="raw", negate=1))
    assert m.unknown.tolist() == [[False, False, True]]
    assert m.values[0, :2].tolist() == [255, 0]


# ------------------------------------------------------------------- map_saver 205 rule


def test_map_saver_rule_with_nav2_thresholds_is_a_debug_note_and_keeps_205_unknown(
        tmp_path, caplog):
    """nav2's saver writes free_thresh 0.25 with 205 as unknown: its own convention, so a
    debug message (slamq -v), not a warning on every map."""
    img = np.array([[0, 205, 254], [255, 205, 0]], np.uint8)
    write_pgm(tmp_path / "nav2.pgm", img)
    y = write_yaml(tmp_path / "nav2.yaml", "nav2.pgm", mode="trinary", free_thresh=0.25)
    with caplog.at_level("DEBUG", logger="slamq"):
        m = load_no_warning(y)
    (note,) = [r.getMessage() for r in caplog.records]
    assert "nav2.yaml" in note and "205" in note and "free_thresh 0.25" in note
    assert m.unknown.tolist() == [[False, True, False], [False, True, False]]
    assert m.meta["unknown_rule"].startswith("map_saver")
    assert m.meta["warnings"] == []


def test_map_saver_rule_warns_when_thresholds_disagree_otherwise(tmp_path):
    write_pgm(tmp_path / "odd.pgm", np.array([[0, 205, 254]], np.uint8))
    y = write_yaml(tmp_path / "odd.yaml", "odd.pgm", free_thresh=0.0)  # 254 would be unknown
    with pytest.warns(MapWarning, match=r"odd.yaml: .*shade\(s\) 254 differently"):
        m = load_map(y)
    assert m.unknown.tolist() == [[False, True, False]]


def test_unknown_value_replaces_the_205_rule_and_its_warning(tmp_path):
    write_pgm(tmp_path / "nav2.pgm", np.array([[0, 205, 254]], np.uint8))
    y = write_yaml(tmp_path / "nav2.yaml", "nav2.pgm", free_thresh=0.25)
    m = load_no_warning(y, unknown_value=254)
    assert m.unknown.tolist() == [[False, False, True]]


def test_map_saver_rule_with_ros1_thresholds_is_silent(tmp_path):
    img = np.array([[0, 205, 254]], np.uint8)
    write_pgm(tmp_path / "m.pgm", img)
    m = load_no_warning(write_yaml(tmp_path / "m.yaml", "m.pgm", free_thresh=0.196))
    assert m.unknown.tolist() == [[False, True, False]]
    assert m.meta["warnings"] == []


def test_map_saver_rule_overrides_negate_and_warns(tmp_path):
    img = np.array([[0, 205, 254]], np.uint8)
    write_pgm(tmp_path / "m.pgm", img)
    with pytest.warns(MapWarning, match="negate"):
        m = load_map(write_yaml(tmp_path / "m.yaml", "m.pgm", negate=1))
    assert m.unknown.tolist() == [[False, True, False]]
    assert m.values.tolist() == [[255, 50, 1]]


def test_graded_map_uses_the_yaml_thresholds_not_the_205_rule(tmp_path):
    img = np.array([[0, 205, 254, 128]], np.uint8)  # 128 breaks the map_saver palette
    write_pgm(tmp_path / "m.pgm", img)
    m = load_no_warning(write_yaml(tmp_path / "m.yaml", "m.pgm", free_thresh=0.25))
    # 205: p = 50/255 = 0.196 < 0.25 -> free; 128: p = 0.498 -> unknown
    assert m.unknown.tolist() == [[False, False, False, True]]
    assert m.meta["unknown_rule"].startswith("thresholds")


def test_bare_image_and_array_defaults(tmp_path):
    img = np.array([[0, 205], [254, 255]], np.uint8)
    for m in (load_no_warning(img), load_no_warning(write_pgm(tmp_path / "b.pgm", img))):
        assert m.unknown.tolist() == [[False, True], [False, False]]
        assert m.resolution is None and m.origin == (0.0, 0.0, 0.0)
        assert m.meta["mode"] == "trinary"
    assert load_no_warning(img).source == "<array>"
    m = load_no_warning(img, resolution=0.1, origin=(1, 2, 3))
    assert m.resolution == 0.1 and m.origin == (1.0, 2.0, 3.0)


def test_pgm_comment_gives_the_resolution_of_a_bare_image(tmp_path):
    p = write_pgm(tmp_path / "m.pgm", ALL_VALUES, comment="CREATOR: map_saver.cpp 0.025 m/pix")
    m = load_no_warning(p)
    assert m.resolution == 0.025 and m.meta["resolution_from"] == "pgm comment"
    assert np.array_equal(m.values, ALL_VALUES)
    assert load_no_warning(p, resolution=0.5).resolution == 0.5
    # the YAML's resolution wins over the comment
    m = load_no_warning(write_yaml(tmp_path / "m.yaml", "m.pgm", resolution=0.05))
    assert m.resolution == 0.05


def test_ascii_pgm_maxval_scaling_and_comments(tmp_path):
    p = tmp_path / "a.pgm"
    p.write_bytes(b"P2\n# hello\n3 2 # trailing comment\n# more\n15\n0 15 7\n# in data\n1 2 15\n")
    m = load_no_warning(p)
    # maxval 15 scales like SDL_image: x * 255 // 15
    assert m.values.tolist() == [[0, 255, 119], [17, 34, 255]]


# ------------------------------------------------------------------ absolute image path


def test_absolute_image_path_falls_back_to_the_file_beside_the_yaml(tmp_path):
    write_pgm(tmp_path / "room.pgm", np.array([[0, 205, 254]], np.uint8))
    y = write_yaml(tmp_path / "room.yaml", "/home/someone/catkin_ws/maps/room.pgm")
    with pytest.warns(MapWarning, match=r"room\.yaml.*does not exist"):
        m = load_map(y)
    assert m.meta["image"] == str(tmp_path / "room.pgm")
    assert m.unknown.tolist() == [[False, True, False]]
    (tmp_path / "room.pgm").unlink()
    with raises_named(y, "not found", "/home/someone/catkin_ws/maps/room.pgm"):
        load_quiet(y)


def test_existing_absolute_image_path_is_used_silently(tmp_path):
    img = write_pgm(tmp_path / "sub.pgm", np.array([[0, 254]], np.uint8))
    (tmp_path / "y").mkdir()
    m = load_no_warning(write_yaml(tmp_path / "y" / "m.yaml", str(img)))
    assert m.meta["image"] == str(img)


# --------------------------------------------------------------------- OccupancyGrid


def test_occupancy_grid_rows_are_flipped_north_up():
    data = np.array([[0, 0, 100],      # row 0 = bottom (y = origin.y)
                     [-1, 50, 0]], np.int8)
    m = load_no_warning(data, resolution=0.05, origin=(1.0, 2.0, 0.0))
    assert m.values.tolist() == [[205, 128, 255], [255, 255, 0]]
    assert m.unknown.tolist() == [[True, False, False], [False, False, False]]
    assert m.resolution == 0.05 and m.origin == (1.0, 2.0, 0.0)
    assert m.meta["kind"] == "occupancy_grid"
    flat = from_occupancy_grid(data.ravel(), width=3, height=2, resolution=0.05)
    assert np.array_equal(flat.values, m.values) and np.array_equal(flat.unknown, m.unknown)
    # any value outside 0..100 is unknown
    odd = from_occupancy_grid(np.array([[101, -2, 127, -128]], np.int8), resolution=None)
    assert odd.unknown.all()
    # plain Python ints in range are accepted
    ints = from_occupancy_grid([[0, 100]], resolution=1.0)
    assert ints.values.tolist() == [[255, 0]]


@pytest.mark.parametrize(
    "kwargs, reason",
    [
        ({"data": np.zeros(5, np.int8), "width": 2, "height": 2}, "5 cells"),
        ({"data": np.zeros(4, np.int8)}, "needs width and height"),
        ({"data": np.zeros((2, 2), np.int8), "width": 3}, "shape"),
        ({"data": np.zeros((2, 2, 2), np.int8)}, "1-D or 2-D"),
        ({"data": np.zeros((2, 2), np.float32)}, "int8"),
        ({"data": np.array([[300]])}, "-128..127"),
        ({"data": np.zeros((0, 3), np.int8)}, "zero cells"),
        ({"data": np.zeros((2, 2), np.int8), "resolution": 0.0}, "resolution must be > 0"),
        ({"data": np.zeros((2, 2), np.int8), "origin": (1.0,)}, "origin"),
    ],
)
def test_occupancy_grid_bad_input(kwargs, reason):
    kwargs.setdefault("resolution", 0.05)
    with raises_named("<g>", reason):
        from_occupancy_grid(source="<g>", **kwargs)


# --------------------------------------------------------------------- unknown_value


def test_unknown_value_forces_pixel_equals_n_and_nothing_else(tmp_path):
    img = np.array([[0, 205, 254, 128, 255]], np.uint8)
    write_pgm(tmp_path / "m.pgm", img)
    y = write_yaml(tmp_path / "m.yaml", "m.pgm")
    m = load_no_warning(y, unknown_value=128)
    assert m.unknown.tolist() == [[False, False, False, True, False]]
    assert m.meta["unknown_rule"] == "unknown_value=128"
    assert load_no_warning(img, unknown_value=205).unknown.tolist() == [
        [False, True, False, False, False]]
    # with negate the pixel is the file's value, before negate
    neg = load_no_warning(write_yaml(tmp_path / "n.yaml", "m.pgm", negate=1), unknown_value=254)
    assert neg.unknown.tolist() == [[False, False, True, False, False]]
    assert neg.values[0, 2] == 1
    # scale mode: alpha no longer counts
    rgba = np.full((1, 2, 4), 254, np.uint8)
    rgba[..., 3] = 255
    rgba[0, 0, 3] = 0
    write_png(tmp_path / "a.png", rgba)
    sa = write_yaml(tmp_path / "a.yaml", "a.png", mode="scale")
    assert load_no_warning(sa).unknown.tolist() == [[True, False]]
    assert load_no_warning(sa, unknown_value=7).unknown.tolist() == [[False, False]]


def test_unknown_value_reapplied_to_a_loaded_map_uses_its_pixels(tmp_path):
    img = np.array([[0, 205, 254, 128]], np.uint8)
    write_pgm(tmp_path / "m.pgm", img)
    m = load_no_warning(write_yaml(tmp_path / "m.yaml", "m.pgm", negate=1))
    assert load_map(m) is m
    assert m.unknown.tolist() == [[False, False, False, True]]  # 205 -> v 50: occupied
    again = load_no_warning(m, unknown_value=205)
    direct = load_no_warning(write_yaml(tmp_path / "m.yaml", "m.pgm", negate=1),
                             unknown_value=205)
    assert np.array_equal(again.unknown, direct.unknown)
    assert again.unknown.tolist() == [[False, True, False, False]]
    assert np.array_equal(again.values, m.values)
    assert m.unknown.tolist() == [[False, False, False, True]]  # the original is untouched
    # a hand-built map: its values are its pixels
    hand = OccupancyMap(img, np.zeros(img.shape, bool))
    assert load_no_warning(hand, unknown_value=0).unknown.tolist() == [[True, False, False,
                                                                        False]]
    # resolution / origin overrides also apply to maps
    assert load_no_warning(hand, resolution=0.2, origin=(1, 1, 0)).resolution == 0.2


def test_unknown_value_on_grids_and_raw(tmp_path):
    data = np.array([[-1, 0, 100, 50]], np.int8)
    assert load_no_warning(data, unknown_value=-1).unknown.tolist() == [[True, False, False,
                                                                         False]]
    assert load_no_warning(data, unknown_value=255).unknown.tolist() == [[True, False, False,
                                                                          False]]
    # making a -1 cell known would invent an occupancy: refused
    with raises_named("<array>", "unknown_value=50", "-1"):
        load_map(data, unknown_value=50)
    g = np.array([[0, 100, 255]], np.uint8)
    write_pgm(tmp_path / "r.pgm", g)
    y = write_yaml(tmp_path / "r.yaml", "r.pgm", mode="raw")
    assert load_no_warning(y, unknown_value=255).unknown.tolist() == [[False, False, True]]
    with raises_named(y, "outside 0..100"):
        load_map(y, unknown_value=0)


@pytest.mark.parametrize("bad", [256, -1, 1.5, "205", True])
def test_unknown_value_out_of_range_is_a_param_error(bad):
    with pytest.raises(ParamError, match="unknown_value"):
        load_map(np.zeros((2, 2), np.uint8), unknown_value=bad)


# ----------------------------------------------------------------------- bad inputs


def test_truncated_pgm(tmp_path):
    p = tmp_path / "cut.pgm"
    p.write_bytes(b"P5\n10 10\n255\n" + bytes(99))
    with raises_named(p, "truncated", "10x10", "99 bytes"):
        load_map(p)
    y = write_yaml(tmp_path / "cut.yaml", "cut.pgm")
    with raises_named(y, "truncated", str(p)):
        load_map(y)


def test_pgm_header_claiming_far_more_cells_fails_fast_without_allocating(tmp_path):
    p = tmp_path / "huge.pgm"
    p.write_bytes(b"P5\n30000 30000\n255\n" + bytes(1000))  # claims 900 M cells
    tracemalloc.start()
    t0 = time.perf_counter()
    try:
        with raises_named(p, "truncated", "900000000 cells"):
            load_map(p)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert time.perf_counter() - t0 < 1.0
    assert peak < 10_000_000
    p2 = tmp_path / "absurd.pgm"
    p2.write_bytes(b"P5 99999999 99999999 255\n" + bytes(10))
    with raises_named(p2, "limit"):
        load_map(p2)


def test_png_header_claiming_far_more_cells_is_refused_before_decoding(tmp_path):
    good = write_png(tmp_path / "g.png", np.full((4, 4), 254, np.uint8)).read_bytes()
    ihdr = struct.pack(">II", 60000, 60000) + good[24:29]
    crc = struct.pack(">I", zlib.crc32(b"IHDR" + ihdr) & 0xFFFFFFFF)
    bomb = good[:16] + ihdr + crc + good[33:]
    p = tmp_path / "bomb.png"
    p.write_bytes(bomb)
    with raises_named(p, "PNG", "60000x60000"):
        load_map(p)


def test_jpeg_truncated_or_claiming_far_more_cells_is_refused(tmp_path):
    img = np.full((64, 48), 254, np.uint8)
    img[10:30, 5:40] = 0
    ok, buf = cv2.imencode(".jpg", img)
    assert ok
    data = buf.tobytes()
    p = tmp_path / "m.jpg"
    p.write_bytes(data)
    assert load_no_warning(p).shape == (64, 48)
    p.write_bytes(data[: len(data) // 2])  # libjpeg would fill the rest with grey
    with raises_named(p, "truncated JPEG"):
        load_map(p)
    sof = data.find(b"\xff\xc0")
    lying = bytearray(data)
    struct.pack_into(">HH", lying, sof + 5, 30000, 30000)
    p.write_bytes(bytes(lying))  # refused before decoding (libjpeg would allocate 900 MB)
    with raises_named(p, "JPEG", "30000x30000"):
        load_map(p)


@pytest.mark.parametrize(
    "content, reason",
    [
        (b"", "empty file"),
        (b"P5\n", "truncated"),
        (b"P5\n4 x\n255\n", "expected a number"),
        (b"P5\n0 10\n255\n", "zero cells"),
        (b"P5\n2 2\n65535\n" + bytes(8), "16-bit"),
        (b"P5\n2 2\n0\n" + bytes(4), "maxval"),
        (b"P5\n2 2\n255", "no pixel data"),
        (b"P5\n2 1\n15\n\x00\x10", "exceeds maxval"),
        (b"P2\n2 2\n255\n1 2 3", "truncated"),
        (b"P2\n2 2\n255\n1 2 3 x", "not a decimal"),
        (b"P2\n2 1\n255\n1 99999999999999999999999", "not a decimal"),
        (b"P2\n2 1\n255\n1 300", "exceeds maxval"),
        (b"P4\n8 1\n\x00", "PBM"),
        (b"hello, this is not an image", "not a readable image"),
    ],
)
def test_bad_image_bytes(tmp_path, content, reason):
    p = tmp_path / "bad.pgm"
    p.write_bytes(content)
    with raises_named(p, reason):
        load_map(p)


def test_16bit_png_is_scaled_16bit_pgm_and_float_tiff_are_refused(tmp_path):
    deep = np.array([[0, 128, 129], [32896, 40000, 65535]], np.uint16)
    p16 = write_png(tmp_path / "deep.png", deep)
    m = load_map(p16)  # v = (x + 128) // 257, docs/spec.md section 1
    assert m.values.tolist() == [[0, 0, 1], [128, 156, 255]]
    assert m.meta["format"] == "PNG (16-bit, scaled)"
    y = write_yaml(tmp_path / "deep.yaml", "deep.png")
    assert np.array_equal(load_map(y).values, m.values)
    pgm16 = tmp_path / "deep.pgm"
    pgm16.write_bytes(b"P5\n2 1\n65535\n" + bytes(4))
    with raises_named(pgm16, "16-bit PGM", "pnmdepth 255"):
        load_map(pgm16)
    ok, buf = cv2.imencode(".tiff", np.full((3, 3), 0.5, np.float32))
    assert ok
    tif = tmp_path / "float.tiff"
    tif.write_bytes(buf.tobytes())
    with raises_named(tif, "float32", "not supported"):
        load_map(tif)


def test_truncated_png(tmp_path):
    rng = np.random.default_rng(1)
    data = write_png(tmp_path / "x.png", rng.integers(0, 256, (64, 64), np.uint8)).read_bytes()
    p = tmp_path / "cut.png"
    p.write_bytes(data[: len(data) // 2])
    with raises_named(p, "truncated PNG"):
        load_map(p)
    p.write_bytes(data[:20])
    with raises_named(p, "PNG"):
        load_map(p)


@pytest.mark.parametrize(
    "text, reason",
    [
        ("resolution: 0.05\norigin: [0, 0, 0]\n", "no 'image' field"),
        ("image: m.pgm\nresolution: 0\n", "resolution must be > 0"),
        ("image: m.pgm\nresolution: -0.05\n", "resolution must be > 0"),
        ("image: m.pgm\nresolution: .nan\n", "resolution must be finite"),
        ("image: m.pgm\nresolution: fast\n", "resolution must be a number"),
        ("image: m.pgm\nresolution: 0.05\norigin: [1, 2, 3, 4]\n", "origin"),
        ("image: [m.pgm\nresolution: 0.05\n", "unparsable YAML"),
        ("image: m.pgm\n\tresolution: 0.05\n", "unparsable YAML"),
        ("- image: m.pgm\n", "not a map YAML"),
        ("", "not a map YAML"),
        ("image: 5\n", "'image' must be a file name"),
        ("image: m.pgm\nmode: ternary\n", "unknown mode 'ternary'"),
        ("image: m.pgm\nnegate: 2\n", "negate must be"),
        ("image: m.pgm\noccupied_thresh: 1.5\n", "occupied_thresh must be in 0..1"),
        ("image: m.pgm\nfree_thresh: abc\n", "free_thresh must be a number"),
        ("image: missing.pgm\nresolution: 0.05\n", "not found"),
        ("image: .\nresolution: 0.05\n", "is a directory"),
    ],
)
def test_bad_yaml(tmp_path, text, reason):
    write_pgm(tmp_path / "m.pgm", np.zeros((2, 2), np.uint8))
    y = tmp_path / "bad.yaml"
    y.write_text(text)
    with raises_named(y, reason):
        load_quiet(y)


def test_yaml_that_is_not_utf8(tmp_path):
    y = tmp_path / "bin.yaml"
    y.write_bytes(b"image: \xff\xfe\x00m.pgm\n")
    with raises_named(y, "unparsable YAML"):
        load_map(y)


def test_yaml_without_resolution_or_origin_loads_with_a_warning(tmp_path):
    write_pgm(tmp_path / "m.pgm", np.zeros((2, 2), np.uint8))
    y = tmp_path / "m.yaml"
    y.write_text("image: m.pgm\n")
    with pytest.warns(MapWarning) as rec:
        m = load_map(y)
    msgs = [str(r.message) for r in rec]
    assert any("no 'resolution'" in x for x in msgs) and any("no 'origin'" in x for x in msgs)
    assert m.resolution is None and m.origin == (0.0, 0.0, 0.0)
    assert load_quiet(y, resolution=0.1).resolution == 0.1


def test_missing_paths_directories_and_odd_sources(tmp_path):
    with raises_named(tmp_path / "nope.yaml", "no such file"):
        load_map(tmp_path / "nope.yaml")
    with raises_named(tmp_path, "is a directory"):
        load_map(tmp_path)
    with raises_named(str(tmp_path / "nope.pgm"), "no such file"):
        load_map(str(tmp_path / "nope.pgm"))
    with raises_named("<array>", "float64"):
        load_map(np.zeros((3, 3)))
    with raises_named("<array>", "zero cells"):
        load_map(np.zeros((0, 3), np.uint8))
    with raises_named("<array>", "shape"):
        load_map(np.zeros((3, 3, 5), np.uint8))
    with raises_named("<array>", "2-D"):
        load_map(np.zeros(3, np.int8))
    with raises_named("<list>", "expected a path"):
        load_map([[0, 1]])
    with raises_named("<array>", "resolution must be > 0"):
        load_map(np.zeros((2, 2), np.uint8), resolution=-1)


@contextlib.contextmanager
def _within(seconds: int):
    """Fail (instead of hanging) when the block takes longer than ``seconds``."""

    def _timeout(*_):
        raise TimeoutError(f"took more than {seconds} s")

    previous = signal.signal(signal.SIGALRM, _timeout)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


def test_hostile_files_fail_fast_naming_the_file_and_reason(tmp_path):
    write_pgm(tmp_path / "m.pgm", np.array([[0, 205, 254]], np.uint8))
    fifo = tmp_path / "fifo.pgm"
    os.mkfifo(fifo)
    (tmp_path / "loop_a.pgm").symlink_to(tmp_path / "loop_b.pgm")
    (tmp_path / "loop_b.pgm").symlink_to(tmp_path / "loop_a.pgm")
    (tmp_path / "dangling.pgm").symlink_to(tmp_path / "nowhere.pgm")
    (tmp_path / "zero.yaml").write_bytes(b"")
    (tmp_path / "binary.yaml").write_bytes(bytes(range(256)) * 4)
    fifo_yaml = tmp_path / "fifo.yaml"
    os.mkfifo(fifo_yaml)
    with _within(10):
        with raises_named(fifo, "not a regular file"):   # open() would block for ever
            load_map(fifo)
        with raises_named(fifo_yaml, "not a regular file"):
            load_map(fifo_yaml)
        with raises_named(write_yaml(tmp_path / "f.yaml", "fifo.pgm"), str(fifo),
                          "not a regular file"):
            load_map(tmp_path / "f.yaml")
        with raises_named(tmp_path / "loop_a.pgm", "symbolic links"):
            load_map(tmp_path / "loop_a.pgm")
        with raises_named(write_yaml(tmp_path / "l.yaml", "loop_a.pgm"), "symbolic links"):
            load_map(tmp_path / "l.yaml")
        with raises_named(tmp_path / "dangling.pgm", "broken symbolic link"):
            load_map(tmp_path / "dangling.pgm")
        with raises_named(tmp_path / "zero.yaml", "not a map YAML"):
            load_map(tmp_path / "zero.yaml")
        with raises_named(tmp_path / "binary.yaml", "unparsable YAML"):
            load_map(tmp_path / "binary.yaml")
        with raises_named(write_yaml(tmp_path / "self.yaml", "self.yaml"), "YAML file"):
            load_map(tmp_path / "self.yaml")
        for text, reason in [
            ("just a sentence\n", "not a map YAML"),
            ("image: m.pgm\nresolution: .inf\n", "resolution must be finite"),
            ("image: m.pgm\nresolution: [0.05]\n", "resolution must be a number"),
            ("image: m.pgm\nresolution: 0.05\norigin: {x: 1, y: 2}\n", "origin"),
            ("image: m.pgm\nresolution: 0.05\norigin: [1, 2, .nan]\n", "origin must be finite"),
            ("image: m.pgm\nresolution: 0.05\norigin: 12\n", "origin"),
            ("image: m.pgm\nnegate: 'yes'\n", "negate must be"),
        ]:
            y = tmp_path / "bad.yaml"
            y.write_text(text)
            with raises_named(y, reason):
                load_quiet(y)
    # YAML 1.1: a bare `yes` is a boolean, so it negates
    y = tmp_path / "yes.yaml"
    y.write_text("image: m.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: yes\n")
    assert load_quiet(y).meta["negate"] is True


def test_bag_paths_dispatch_to_the_bag_reader(tmp_path):
    # An empty .bag is no bag: whatever reads it must say so as a MapError naming it.
    p = tmp_path / "empty.bag"
    p.write_bytes(b"")
    with pytest.raises(MapError, match="empty.bag"):
        load_map(p)


def test_every_error_is_a_slamq_error(tmp_path):
    p = tmp_path / "cut.pgm"
    p.write_bytes(b"P5\n10 10\n255\n")
    with pytest.raises(slamq.SlamqError):
        load_map(p)
    with pytest.raises(ValueError):  # MapError is also a ValueError
        load_map(p)


# ---------------------------------------------------------------- shipped fixtures


def test_shipped_fixtures_load(test_data):
    office = test_data / "slam_comparison_tools" / "test_results" / "office"
    for name in ("cartographer", "gmapping", "lidar_rtabmap", "rgbd_rtabmap", "slam_toolbox"):
        m = load_no_warning(office / f"{name}_map.yaml")  # nav2's convention: no warning
        assert m.resolution == 0.05
        assert m.meta["unknown_rule"].startswith("map_saver")
        assert np.array_equal(m.unknown, m.values == 205)
        assert 0 < m.known_count < m.values.size
    gt = load_quiet(test_data / "slam_comparison_tools" / "ground_truths"
                    / "office_ground_truth.yaml")
    assert gt.shape == (364, 495)
    for name in ("cartographer", "gmapping"):
        with pytest.warns(MapWarning, match="does not exist"):
            m = load_map(test_data / "ros_whill_arc" / f"{name}.yaml")
        assert m.resolution == 0.05
    intel = load_no_warning(test_data / "utexas_gdc_large" / "intel_lab" / "intel.yaml")
    assert intel.shape == (581, 579) and intel.resolution == 0.1
    # graded map, thresholds 0.05 <= p <= 0.2  <=>  204 <= v <= 242
    v = intel.values
    assert np.array_equal(intel.unknown, (v >= 204) & (v <= 242))


# ------------------------------------------------------------------ the real corpus

#: Files of ../shared/data/maps that must fail, and why.
EXPECTED_FAILURES = {
    "awabot_trajectoire4_4/trajectoire4_4_hector.yaml": "not found",  # pgm absent (>4 MB)
    "nanobot/new_maps/crsm.yaml": "not found",  # names crsm.pgm; only crsm_processed.pgm
    "nanobot/new_maps/gmapping.yaml": "not found",
    "nanobot/new_maps/hector.yaml": "not found",
}


def _pgm_size(path: Path) -> tuple[int, int]:
    tokens: list[bytes] = []
    for line in path.read_bytes()[:200].split(b"\n")[1:]:
        if not line.startswith(b"#"):
            tokens += line.split()
        if len(tokens) >= 2:
            return int(tokens[1]), int(tokens[0])
    raise AssertionError(path)


def test_every_map_of_the_shared_corpus_loads_or_fails_clearly(shared_data):
    root = shared_data / "maps"
    files = sorted(p for p in root.rglob("*")
                   if p.suffix.lower() in (".yaml", ".pgm", ".png"))
    assert len(files) > 150
    loaded = 0
    for p in files:
        rel = p.relative_to(root).as_posix()
        if rel in EXPECTED_FAILURES:
            with raises_named(p, EXPECTED_FAILURES[rel]):
                load_quiet(p)
            continue
        m = load_quiet(p)
        loaded += 1
        h, w = m.shape
        assert h >= 100 and w >= 100, rel
        assert m.values.flags.c_contiguous and m.unknown.flags.c_contiguous
        if p.suffix == ".pgm":
            assert m.shape == _pgm_size(p), rel
        elif p.suffix == ".yaml":
            assert m.shape == _pgm_size(Path(m.meta["image"])), rel
            assert m.resolution in (0.025, 0.05, 0.1), rel
        assert 0 <= m.known_count <= h * w
        pixels = m.meta["pixels"]
        if m.meta["unknown_rule"].startswith("map_saver"):
            assert np.array_equal(m.unknown, pixels == 205), rel
        if "nanobot/new_maps/" in rel and "_processed" in rel:
            assert m.known_count == h * w  # binarised: no unknown at all
        elif "dakitec" not in rel:
            assert 0.02 < m.known_count / (h * w) < 0.99, rel
    assert loaded == len(files) - len(EXPECTED_FAILURES)


def test_awabot_128_unknown_loads_correctly_under_its_yaml_thresholds(shared_data):
    p = shared_data / "maps" / "awabot_trajectoire4_4" / "trajectoire4_4_gmapping.yaml"
    m = load_no_warning(p)
    pixels = m.meta["pixels"]
    assert sorted(np.unique(pixels).tolist()) == [0, 128, 255]
    assert np.array_equal(m.unknown, pixels == 128)  # p = 0.498 lies in [0.196, 0.65]


def test_yaml_and_bare_pgm_of_the_same_map_agree(shared_data):
    d = shared_data / "maps" / "lfz1994_robot_navigation"
    a = load_no_warning(d / "karto.yaml")
    with pytest.warns(MapWarning, match="karto.yaml beside it names this image"):
        b = load_map(d / "karto.pgm")
    assert np.array_equal(a.values, b.values) and np.array_equal(a.unknown, b.unknown)
    assert b.resolution == 0.05  # from "# CREATOR: map_saver.cpp 0.050 m/pix"
    assert a.origin == (-1.533525, -2.227791, 0.0)


def test_pnm_parser_agrees_with_opencv_on_the_corpus(shared_data):
    for p in sorted((shared_data / "maps").rglob("*.pgm"))[:40]:
        ours = load_quiet(p).meta["pixels"]
        theirs = cv2.imread(str(p), cv2.IMREAD_UNCHANGED)
        assert np.array_equal(ours, theirs), p


# ------------------------------------------------------------ property: an independent loop

def _expected_unknown(pixel: int, negate: bool, occ: float, free: float, saver: bool) -> bool:
    if saver:
        return pixel == 205
    v = 255 - pixel if negate else pixel
    p = (255 - v) / 255
    return free <= p <= occ


@settings(max_examples=40, deadline=None)
@given(
    img=arrays(np.uint8, st.tuples(st.integers(1, 12), st.integers(1, 12)),
               elements=st.sampled_from([0, 1, 89, 90, 128, 204, 205, 206, 254, 255])),
    negate=st.booleans(),
    occ=st.sampled_from([0.65, 0.5, 100 / 255, 1.0]),
    free=st.sampled_from([0.196, 0.25, 50 / 255, 0.0]),
    ascii_=st.booleans(),
)
def test_pgm_round_trip_and_unknown_rule_match_a_per_pixel_loop(
    tmp_path_factory, img, negate, occ, free, ascii_
):
    d = tmp_path_factory.mktemp("prop")
    h, w = img.shape
    if ascii_:
        body = "\n".join(" ".join(str(int(x)) for x in row) for row in img)
        (d / "m.pgm").write_bytes(f"P2\n{w} {h}\n255\n{body}\n".encode())
    else:
        write_pgm(d / "m.pgm", img)
    y = write_yaml(d / "m.yaml", "m.pgm", negate=int(negate), occupied_thresh=repr(occ),
                   free_thresh=repr(free))
    m = load_quiet(y)
    saver = set(np.unique(img).tolist()) <= {0, 205, 254, 255}
    expected = [[_expected_unknown(int(x), negate, occ, free, saver) for x in row]
                for row in img]
    assert m.unknown.tolist() == expected
    assert m.meta["pixels"].tolist() == img.tolist()
    assert m.values.tolist() == (255 - img if negate else img).tolist()


def test_non_contiguous_and_grey_alpha_arrays():
    a = np.arange(96, dtype=np.uint8).reshape(4, 24)
    m = load_no_warning(a[::-1, ::3])
    assert np.array_equal(m.values, a[::-1, ::3]) and m.values.flags.c_contiguous
    assert np.array_equal(m.unknown, (a[::-1, ::3] >= 90) & (a[::-1, ::3] <= 205))
    la = np.dstack([a, np.full_like(a, 255)])
    m = load_no_warning(la)
    assert np.array_equal(m.values, a) and m.meta["channels"] == 2
    g = np.array([[1, 2], [3, 4]], np.int8)[:, ::-1]
    assert load_no_warning(g).values.tolist() == [[245, 247], [250, 252]]  # [[4, 3], [2, 1]]


def test_a_bare_image_that_is_mostly_unknown_is_a_warning(tmp_path):
    """An RViz screenshot (free grey 192) loads almost all unknown under map_server's
    defaults: say so, and how to fix it."""
    img = np.full((40, 40), 192, np.uint8)
    img[10:30, 10] = 0
    write_pgm(tmp_path / "shot.pgm", img)
    with pytest.warns(MapWarning, match=r"shot.pgm: 98.8% of the cells are unknown.*"
                      r"--unknown-value N"):
        m = load_map(tmp_path / "shot.pgm")
    assert m.known_count == 20
    load_no_warning(tmp_path / "shot.pgm", unknown_value=205)  # told how to read it: quiet


def test_a_yaml_added_beside_a_bare_image_is_noticed_despite_the_listing_cache(tmp_path):
    img = tmp_path / "m.pgm"
    img.write_bytes(b"P5 3 1 255 " + bytes([0, 254, 254]))
    old = 1_000_000_000  # an old folder: its listing is cached by mtime
    os.utime(tmp_path, ns=(old, old))
    with warnings.catch_warnings():
        warnings.simplefilter("error", MapWarning)
        load_map(img)  # no YAML yet; the listing is now cached
    (tmp_path / "m.yaml").write_text("image: m.pgm\nresolution: 0.05\n")  # new mtime
    with pytest.warns(MapWarning, match="m.yaml beside it names this image"):
        load_map(img)
    os.utime(tmp_path, ns=(old + 1, old + 1))  # old again, another mtime: listed anew
    (tmp_path / "m.yaml").unlink()
    os.utime(tmp_path, ns=(old + 2, old + 2))
    with warnings.catch_warnings():
        warnings.simplefilter("error", MapWarning)
        load_map(img)
