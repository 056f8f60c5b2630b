"""slamq timeline (metrics over time from a bag), slamq eval on a bag, slamq.report.animation."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest
from _bagdata import BagWriter, bag_path, room_grid
from PIL import Image

import slamq
from slamq import BagError, OccupancyMap
from slamq.cli import main
from slamq.models import MapQuality
from slamq.report.animation import UNKNOWN_RGB, render_frames, render_map, write_gif
from slamq.report.timeline import timeline
from slamq.sources.bag_maps import read_bag_maps

GRID = "nav_msgs/msg/OccupancyGrid"
RES = 0.1


def growing_run(path, fmt="ros1", n=7):
    """A room mapped from right to left: the canvas grows to the left, the room closes last.

    Map i covers 30 + 4*i columns (the last one all 48); its origin moves left so the world
    stays put.
    """
    full = room_grid(size=40)  # 48 x 48, walls closed
    with BagWriter(path, fmt) as w:
        for i in range(n):
            width = full.shape[1] if i == n - 1 else min(full.shape[1], 30 + 4 * i)
            g = full[:, -width:].copy()  # free cells reach the left edge until the last map
            origin = (-1.0 + (full.shape[1] - width) * RES, 2.0, 0.0)
            w.write("/map", GRID, w.grid(100.0 + i, g, resolution=RES, origin=origin))
    return path


@pytest.fixture(scope="module")
def run_bag(tmp_path_factory):
    return growing_run(bag_path(tmp_path_factory.mktemp("bags"), "ros1"))


def test_timeline_outputs(run_bag, tmp_path):
    out = tmp_path / "tl"
    rows = timeline(run_bag, out, every=4, sweep_step=5)
    # maps 0 and 4, and the last one (6) although every=4 skips it
    assert [r["index"] for r in rows] == [0, 4, 6]
    assert [r["timestamp"] for r in rows] == [100.0, 104.0, 106.0]
    assert [r["elapsed"] for r in rows] == [0.0, 4.0, 6.0]
    fields = [f for f in MapQuality.__dataclass_fields__ if f not in ("curve", "params", "extra")]
    for r in rows:
        assert set(fields) <= set(r) and "curve" not in r
        assert r["param_sweep_step"] == 5
    # the metrics are those of slamq.evaluate on the same maps
    maps = [m for _, m in read_bag_maps(run_bag)]
    for r in rows:
        q = slamq.evaluate(maps[r["index"]], sweep_step=5)
        assert (r["corners"], r["enclosed_areas"], r["occupied"]) == (
            q.corners, q.enclosed_areas, q.occupied)
    assert rows[0]["enclosed_areas"] == 0 and rows[-1]["enclosed_areas"] == 1
    assert rows[0]["width"] < rows[-1]["width"] == 48

    lines = (out / "metrics.jsonl").read_text().splitlines()
    assert [json.loads(line) for line in lines] == rows
    with open(out / "metrics.csv", newline="") as f:
        table = list(csv.DictReader(f))
    assert len(table) == 3 and table[0].keys() >= {"index", "timestamp", *fields}
    assert [int(t["corners"]) for t in table] == [r["corners"] for r in rows]

    pngs = sorted((out / "frames").glob("*.png"))
    assert [p.name for p in pngs] == ["frame_00000.png", "frame_00001.png", "frame_00002.png"]
    assert Image.open(pngs[-1]).size == (48, 48)
    gif = Image.open(out / "timeline.gif")
    assert gif.n_frames == 3
    assert gif.size == (48, 48 + 3)  # the canvas of all maps, plus the progress bar
    plot = Image.open(out / "metrics.png")
    assert plot.format == "PNG" and plot.size[0] >= 300


def test_timeline_every_one_and_options(run_bag, tmp_path):
    rows = timeline(run_bag, tmp_path, every=1, frames=False, plot=False, max_size=20,
                    sweep_step=16)
    assert [r["index"] for r in rows] == list(range(7))
    assert not (tmp_path / "frames").exists() and not (tmp_path / "metrics.png").exists()
    gif = Image.open(tmp_path / "timeline.gif")
    assert gif.n_frames == 7 and max(gif.size) <= 20 + 3


def test_timeline_errors(tmp_path, run_bag):
    with pytest.raises(BagError, match=r"no topic /grid; topics in the bag: /map"):
        timeline(run_bag, tmp_path / "a", topic="/grid")
    with pytest.raises(slamq.ParamError, match="sweep_step"):
        timeline(run_bag, tmp_path / "b", sweep_step=0)
    with pytest.raises(slamq.ParamError, match="unknown parameter"):
        timeline(run_bag, tmp_path / "c", sweep_stp=2)


def test_cli_timeline(run_bag, tmp_path, capsys):
    out = tmp_path / "cli"
    code = main(["timeline", str(run_bag), "--every", "3", "--out", str(out),
                 "--sweep-step", "8", "--max-size", "32"])
    assert code == 0
    text = capsys.readouterr().out
    assert "3 maps from" in text
    rows = [json.loads(x) for x in (out / "metrics.jsonl").read_text().splitlines()]
    assert [r["index"] for r in rows] == [0, 3, 6] and rows[0]["param_sweep_step"] == 8
    assert Image.open(out / "timeline.gif").n_frames == 3

    missing = tmp_path / "nope.bag"
    assert main(["timeline", str(missing), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "nope.bag" in err[0] and "no such file" in err[0]
    assert main(["timeline", str(run_bag), "--out", str(out), "--every", "0"]) == 2


@pytest.mark.parametrize("fmt", ["ros1", "sqlite3", "mcap"])
def test_cli_truncated_bag_exits_2_with_one_line(tmp_path, capsys, fmt):
    good = growing_run(bag_path(tmp_path, fmt, "good"), fmt, n=3)
    bad = growing_run(bag_path(tmp_path, fmt, "bad"), fmt, n=3)
    data = bad if bad.is_file() else next(p for p in bad.iterdir() if p.suffix != ".yaml")
    data.write_bytes(data.read_bytes()[: data.stat().st_size // 2])
    assert main(["timeline", str(bad), "--out", str(tmp_path / "t")]) == 2
    captured = capsys.readouterr()
    err = captured.err.strip().splitlines()
    assert len(err) == 1 and bad.name in err[0] and "truncated" in err[0], err
    assert "Traceback" not in captured.err
    # slamq eval: the bad bag is reported, the good one still evaluated
    assert main(["eval", str(good), str(bad), "--sweep-step", "16"]) == 2
    captured = capsys.readouterr()
    err = captured.err.strip().splitlines()
    assert len(err) == 1 and bad.name in err[0] and "truncated" in err[0], err
    assert good.name in captured.out


@pytest.mark.parametrize("fmt", ["ros1", "sqlite3", "mcap"])
def test_cli_eval_on_a_bag_evaluates_the_last_map(tmp_path, capsys, fmt):
    bag = growing_run(bag_path(tmp_path, fmt), fmt, n=3)
    target = bag if fmt == "ros1" else next(bag.glob("*.db3"), bag)  # a file or the folder
    # slamq.evaluate on the bag path: load_map dispatches to read_last_map
    direct = slamq.evaluate(target, sweep_step=4)
    expected = slamq.evaluate(slamq.sources.bag_maps.read_last_map(bag), sweep_step=4)
    assert direct.enclosed_areas == expected.enclosed_areas == 1
    assert (direct.corners, direct.occupied) == (expected.corners, expected.occupied)
    pytest.importorskip("slamq.results.table")
    json_out = tmp_path / "q.json"
    assert main(["eval", str(target), "--sweep-step", "4", "--json", str(json_out)]) == 0
    capsys.readouterr()
    data = json.loads(json_out.read_text())
    got = data[0] if isinstance(data, list) else data
    assert (got["corners"], got["enclosed_areas"], got["occupied"]) == (
        expected.corners, expected.enclosed_areas, expected.occupied)


# ----------------------------------------------------------------------------- animation


def test_render_map():
    values = np.array([[0, 100], [200, 255]], np.uint8)
    unknown = np.array([[False, False], [True, False]])
    rgb = render_map(OccupancyMap(values, unknown))
    assert rgb.dtype == np.uint8 and rgb.shape == (2, 2, 3)
    assert rgb[0, 1].tolist() == [100] * 3 and rgb[1, 0].tolist() == list(UNKNOWN_RGB)
    big = OccupancyMap(np.zeros((300, 100), np.uint8), np.zeros((300, 100), bool))
    assert render_map(big, max_size=30).shape == (30, 10, 3)
    assert render_map(big, max_size=1000).shape == (300, 100, 3)  # never enlarged


def test_render_frames_keeps_the_world_in_place():
    # the same wall cell, seen in a small map and in a bigger one grown left and down
    a = np.full((4, 4), 254, np.uint8)
    a[0, 0] = 0
    b = np.full((10, 8), 254, np.uint8)
    b[0, 4] = 0  # 4 columns of new map on the left; the top row is shared
    ma = OccupancyMap(a, np.zeros_like(a, bool), 0.5, (2.0, 3.0, 0.0))
    mb = OccupancyMap(b, np.zeros_like(b, bool), 0.5, (0.0, 0.0, 0.0))
    fa, fb = render_frames([ma, mb], max_size=None)
    assert fa.shape == fb.shape == (10, 8, 3)
    assert fa[0, 4].tolist() == fb[0, 4].tolist() == [0, 0, 0]
    assert fa[9, 0].tolist() == list(UNKNOWN_RGB)  # outside the small map
    # different resolutions cannot be aligned: centred instead, same size
    mc = OccupancyMap(a, np.zeros_like(a, bool), 0.25, (0.0, 0.0, 0.0))
    fa2, fc = render_frames([mb, mc], max_size=5)
    assert fa2.shape == fc.shape and max(fa2.shape[:2]) == 5


def test_write_gif(tmp_path):
    frames = [np.full((5, 6, 3), v, np.uint8) for v in (0, 60, 120)]
    frames.append(np.full((7, 3), 200, np.uint8))  # grey and another size: padded
    p = write_gif(frames, tmp_path / "sub" / "x.gif", duration_ms=50)
    gif = Image.open(p)
    assert gif.n_frames == 4 and gif.size == (6, 7)
    assert gif.info["duration"] == 50
    gif.seek(1)
    assert gif.convert("RGB").getpixel((0, 0)) == (60, 60, 60)
    with pytest.raises(ValueError, match="at least one frame"):
        write_gif([], tmp_path / "y.gif")


def test_cli_eval_on_a_bag_reads_the_topic_it_is_given(tmp_path, capsys):
    bag = bag_path(tmp_path, "ros1")
    with BagWriter(bag, "ros1") as w:
        w.write("/map", GRID, w.grid(1.0, room_grid(size=20), resolution=RES))
        w.write("/local_map", GRID, w.grid(1.0, room_grid(size=40), resolution=RES))
    out = tmp_path / "q.json"
    assert main(["eval", str(bag), "--topic", "/local_map", "--json", str(out)]) == 0
    (got,) = json.loads(out.read_text())
    assert (got["height"], got["width"]) == (48, 48)
    assert main(["eval", str(bag), "--json", str(out)]) == 0  # default /map: 28 x 28
    assert json.loads(out.read_text())[0]["height"] == 28
    assert main(["eval", str(bag), "--topic", "/nothing"]) == 2
    assert "no topic /nothing" in capsys.readouterr().err
