"""The map-format registry (slamq.sources.formats): a format defined here, a tiny text grid,
is registered and found by load_map, ``slamq eval``, ``slamq batch`` / evaluate_many, the
folder walk and the batch's content hash; the built-in formats it replaces agree with the
readers they wrap (MRPT grids, map_server writing, run outputs collected)."""

from __future__ import annotations

import json
import types
from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np
import pytest

import slamq
from slamq.batch.records import content_hash, map_files
from slamq.cli import main
from slamq.errors import MapError
from slamq.sources import discover_maps, formats
from slamq.sources.formats import RawMap
from slamq.sources.images import Image
from slamq.sources.mrpt import load_mrpt_grid

# --------------------------------------------------------------------------- the toy format
# A ".tgrid" file: "tgrid <resolution>" then one text row per map row: '#' occupied,
# '.' free, '?' unknown. An optional "<name>.origin" file beside it holds "x y yaw".

_SHADES = {"#": 0, ".": 254, "?": 205}


def _origin_file(path: Path) -> Path:
    return path.with_name(path.name + ".origin")


def _sniff(path: Path) -> bool:
    return path.suffix == ".tgrid"


def _files(path: Path) -> list[Path]:
    side = _origin_file(path)
    return [path, side] if side.is_file() else [path]


def _read(path: Path) -> RawMap:
    head, *rows = path.read_text().splitlines()
    kind, res = head.split()
    if kind != "tgrid" or not rows or len({len(r) for r in rows}) != 1:
        raise MapError(f"{path}: not a tgrid map")
    grey = np.array([[_SHADES[c] for c in r] for r in rows], np.uint8)
    side = _origin_file(path)
    origin = (0.0, 0.0, 0.0)
    if side.is_file():
        x, y, yaw = (float(v) for v in side.read_text().split())
        origin = (x, y, yaw)
    return RawMap(str(path), image=Image(grey, None, 1, None, "tgrid"),
                  resolution=float(res), origin=origin, meta={"kind": "tgrid"})


TOY = types.SimpleNamespace(NAME="tgrid", sniff=_sniff, files=_files, read=_read)

_ROOM = ["tgrid 0.1"] + ["#" * 24] + ["#" + "." * 22 + "#"] * 14 + ["#" * 24] + \
        ["?" * 24] * 3


@pytest.fixture
def toy() -> Iterator[types.SimpleNamespace]:
    formats.register_format(TOY)
    try:
        yield TOY
    finally:
        formats.unregister_format("tgrid")


def _write_toy(path: Path, lines: list[str] = _ROOM) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join(lines) + "\n")
    return path


def _same_room_as_pgm(path: Path) -> Path:
    grey = np.array([[_SHADES[c] for c in r] for r in _ROOM[1:]], np.uint8)
    h, w = grey.shape
    path.write_bytes(f"P5\n{w} {h}\n255\n".encode() + grey.tobytes())
    path.with_suffix(".yaml").write_text(
        f"image: {path.name}\nresolution: 0.1\norigin: [0, 0, 0]\n")
    return path.with_suffix(".yaml")


def test_an_unregistered_format_is_not_a_map(tmp_path: Path) -> None:
    p = _write_toy(tmp_path / "room.tgrid")
    assert formats.format_of(p) is None
    maps, problems = discover_maps([tmp_path, p])
    assert maps == [] and [r for _, r in problems][0].startswith("not a map file")
    with pytest.raises(MapError, match="room.tgrid"):
        slamq.load_map(p)


def test_load_map_reads_a_registered_format(tmp_path: Path, toy: object) -> None:
    p = _write_toy(tmp_path / "room.tgrid")
    _origin_file(p).write_text("1.5 -2 0\n")
    m = slamq.load_map(p)
    assert m.shape == (19, 24) and m.resolution == 0.1 and m.origin == (1.5, -2.0, 0.0)
    assert int(m.unknown.sum()) == 72 and int((m.values == 0).sum()) == 2 * 24 + 2 * 14
    assert m.meta["kind"] == "tgrid"
    # the same cells as the map_server map of the same pixels: one interpret step
    ref = slamq.load_map(_same_room_as_pgm(tmp_path / "ref.pgm"))
    assert np.array_equal(m.values, ref.values) and np.array_equal(m.unknown, ref.unknown)
    assert slamq.evaluate(m).to_dict()["proportion"] == \
        slamq.evaluate(ref).to_dict()["proportion"]
    # unknown_value and resolution are applied to it as to any format
    assert slamq.load_map(p, unknown_value=254).unknown.sum() == 22 * 14
    assert slamq.load_map(p, resolution=0.5).resolution == 0.5
    # a topic (for the bags among the sources) is no concern of a map file
    assert np.array_equal(slamq.load_map(p, topic="/map").values, m.values)
    assert slamq.load_map(ref.source, topic="/map").shape == ref.shape


def test_the_walk_and_the_hash_ask_the_registry(tmp_path: Path, toy: object) -> None:
    p = _write_toy(tmp_path / "maps" / "room.tgrid")
    _write_toy(tmp_path / "maps" / "deep" / "other.tgrid")
    side = _origin_file(p)
    side.write_text("0 0 0\n")
    maps, problems = discover_maps(tmp_path)
    assert [m.name for m in maps] == ["room.tgrid", "other.tgrid"] and problems == []
    assert map_files(p) == [p, side]
    before = content_hash(p)
    side.write_text("1 0 0\n")  # a file of the map changed: so did its hash
    assert content_hash(p) != before


def test_slamq_eval_finds_a_registered_format(tmp_path: Path, toy: object,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    p = _write_toy(tmp_path / "room.tgrid")
    out = tmp_path / "eval.json"
    assert main(["eval", str(tmp_path), "--json", str(out)]) == 0
    rows = json.loads(out.read_text())
    rows = rows if isinstance(rows, list) else [rows]
    assert [Path(r["source"]).name for r in rows] == [p.name]
    expected = slamq.evaluate(slamq.load_map(p)).to_dict()
    assert rows[0]["proportion"] == expected["proportion"]
    assert rows[0]["enclosed_areas"] == expected["enclosed_areas"]


def test_slamq_batch_finds_a_registered_format(tmp_path: Path, toy: object) -> None:
    p = _write_toy(tmp_path / "runs" / "room.tgrid")
    yaml = _same_room_as_pgm(tmp_path / "runs" / "ref.pgm")
    recs = {Path(r["map"]).name: r for r in slamq.evaluate_many(tmp_path / "runs", threads=1)}
    assert set(recs) == {p.name, yaml.name}
    assert recs[p.name]["error"] is None and recs[p.name]["hash"] == content_hash(p)
    assert recs[p.name]["proportion"] == recs[yaml.name]["proportion"]
    out = tmp_path / "results.jsonl"
    assert main(["batch", str(tmp_path / "runs"), "--out", str(out), "--no-progress"]) == 0
    stored = [json.loads(line) for line in out.read_text().splitlines()]
    assert sorted(Path(r["map"]).name for r in stored) == sorted(recs)
    assert all(r["error"] is None for r in stored)


def test_registering_checks_names(toy: object) -> None:
    with pytest.raises(ValueError, match="registered already"):
        formats.register_format(TOY)
    with pytest.raises(TypeError, match="no map format"):
        formats.register_format(types.SimpleNamespace(NAME="half", sniff=_sniff))
    with pytest.raises(ValueError, match="no registered map format"):
        formats.unregister_format("image")  # the built-ins stay
    assert [f.name for f in formats.map_formats()][0] == "tgrid"


# --------------------------------------------------------------------------- built-ins


def _mrpt_grid(d: Path) -> Path:
    img = np.full((20, 40), 128, np.uint8)
    img[:10, :] = 255
    img[0, :] = 0
    png = d / "finalMap_00.png"
    cv2.imwrite(str(png), img)
    (d / "finalMap_00_limits.txt").write_text("% Grid limits\n-2.0 2.0 -1.0 1.0\n")
    return png


def test_load_map_reads_an_mrpt_grid(tmp_path: Path) -> None:
    png = _mrpt_grid(tmp_path)
    m, ref = slamq.load_map(png), load_mrpt_grid(png)
    assert formats.format_of(png).name == "mrpt_grid"
    assert np.array_equal(m.values, ref.values) and np.array_equal(m.unknown, ref.unknown)
    assert m.resolution == pytest.approx(0.1) and m.origin == (-2.0, -1.0, 0.0)
    assert [p.name for p in map_files(png)] == ["finalMap_00.png", "finalMap_00_limits.txt"]
    assert discover_maps(tmp_path)[0] == [png]
    # the map_server YAML a run's output becomes reads back to the same cells
    y = formats.collect_map(png, tmp_path / "run" / "map.yaml", format="mrpt")
    back = slamq.load_map(y)
    assert np.array_equal(back.values, m.values) and back.origin == m.origin
    # without its limits it is a bare image again
    (tmp_path / "finalMap_00_limits.txt").unlink()
    assert formats.format_of(png).name == "image"
    assert slamq.load_map(png).resolution is None


def test_map_server_write_and_collect_round_trip(tmp_path: Path) -> None:
    grid = slamq.sources.from_occupancy_grid(
        np.array([[0, 100, -1], [50, 37, 0]], np.int8), resolution=0.05, origin=(1, 2, 0))
    fmt = formats.get_format("map_server")
    assert fmt.write is not None
    y = fmt.write(grid, tmp_path / "m.yaml")
    back = slamq.load_map(y)
    assert np.array_equal(back.values, grid.values) and np.array_equal(back.unknown,
                                                                        grid.unknown)
    assert formats.collect_map(y, tmp_path / "other.yaml") == y  # readable as it is
    with pytest.raises(MapError, match="no map format named"):
        formats.get_format("gridmap")


def test_a_yaml_that_is_no_map_is_named_when_loaded_and_skipped_by_the_walk(
        tmp_path: Path) -> None:
    cfg = tmp_path / "config.yaml"
    cfg.write_text("rate: 10\n")
    assert discover_maps(tmp_path) == ([], [])
    with pytest.raises(MapError, match="no 'image' field"):
        slamq.load_map(cfg)
