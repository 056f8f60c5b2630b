"""discover_maps: which files of a folder are maps, each map once."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

import slamq
from slamq.sources import discover_maps, load_map


def _pgm(path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(b"P5 2 2 255\n" + bytes([0, 205, 254, 254]))
    return path


def _yaml(path: Path, image: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(f"image: {image}\nresolution: 0.05\norigin: [0, 0, 0]\n")
    return path


def test_folder_yields_yaml_maps_and_unnamed_images_once(tmp_path):
    _pgm(tmp_path / "a.pgm")
    _yaml(tmp_path / "a.yaml", "a.pgm")
    _pgm(tmp_path / "stray.pgm")                       # no YAML names it
    _pgm(tmp_path / "sub" / "b.pgm")
    _yaml(tmp_path / "sub" / "b.yml", "/somewhere/else/b.pgm")  # absolute -> basename
    (tmp_path / "sub" / "params.yaml").write_text("max_range: 8\n")  # not a map
    (tmp_path / "notes.txt").write_text("hello")
    _pgm(tmp_path / ".hidden" / "h.pgm")
    bag = tmp_path / "rosbag2_run"                     # a ROS 2 bag folder: skipped
    bag.mkdir()
    (bag / "metadata.yaml").write_text("rosbag2_bagfile_information: {}\n")
    _pgm(bag / "inside.pgm")
    maps, problems = discover_maps(tmp_path)
    rel = [p.relative_to(tmp_path).as_posix() for p in maps]
    assert rel == ["a.yaml", "stray.pgm", "sub/b.yml"]
    assert problems == []
    for p in maps:
        m = load_map(p) if p.suffix == ".pgm" else None
        if m is not None:
            assert m.unknown.tolist() == [[False, True], [False, False]]


def test_an_image_named_through_another_path_is_not_a_second_map(tmp_path):
    # the YAML names its image by a path that differs from the folder listing's (a ".."
    # detour, a symlink): the image is still the YAML's, found by resolving both
    _pgm(tmp_path / "real.pgm")
    (tmp_path / "link.pgm").symlink_to(tmp_path / "real.pgm")
    (tmp_path / "sub").mkdir()
    _yaml(tmp_path / "m.yaml", "sub/../link.pgm")
    _pgm(tmp_path / "other.pgm")
    maps, problems = discover_maps(tmp_path)
    assert [p.name for p in maps] == ["m.yaml", "other.pgm"]
    assert problems == []


def test_missing_paths_unparsable_yaml_and_unsupported_files_are_problems(tmp_path):
    _pgm(tmp_path / "ok.pgm")
    (tmp_path / "broken.yaml").write_text("image: [oops\n")
    (tmp_path / "notes.txt").write_text("hello")
    maps, problems = discover_maps([tmp_path, tmp_path / "gone.yaml", tmp_path / "notes.txt"])
    # an unparsable YAML is a map (as in slamq batch): loading it says why
    assert [p.name for p in maps] == ["broken.yaml", "ok.pgm"]
    with pytest.raises(slamq.MapError, match="broken.yaml: unparsable YAML"):
        slamq.load_map(maps[0])
    reasons = {Path(p).name: r for p, r in problems}
    assert reasons["gone.yaml"] == "no such file or directory"
    assert reasons["notes.txt"].startswith("not a map file")
    assert "broken.yaml" not in reasons


def test_explicit_files_are_kept_and_duplicates_dropped(tmp_path):
    img = _pgm(tmp_path / "a.pgm")
    y = _yaml(tmp_path / "a.yaml", "a.pgm")
    bag = tmp_path / "run.bag"
    bag.write_bytes(b"")
    bagdir = tmp_path / "r2"
    bagdir.mkdir()
    (bagdir / "metadata.yaml").write_text("rosbag2_bagfile_information: {}\n")
    maps, problems = discover_maps([img, y, str(y), tmp_path, bag, bagdir])
    assert maps == [img, y, bag, bagdir]
    assert problems == []


def test_discovering_the_shipped_fixtures(test_data):
    maps, problems = discover_maps([test_data])
    names = sorted(p.relative_to(test_data).as_posix() for p in maps)
    assert problems == []
    assert names == [
        "ros_whill_arc/cartographer.yaml",
        "ros_whill_arc/gmapping.yaml",
        "slam_comparison_tools/ground_truths/office_ground_truth.yaml",
        "slam_comparison_tools/test_results/office/cartographer_map.yaml",
        "slam_comparison_tools/test_results/office/gmapping_map.yaml",
        "slam_comparison_tools/test_results/office/lidar_rtabmap_map.yaml",
        "slam_comparison_tools/test_results/office/rgbd_rtabmap_map.yaml",
        "slam_comparison_tools/test_results/office/slam_toolbox_map.yaml",
        "utexas_gdc_large/intel_lab/intel.yaml",
    ]


def test_discovering_the_shared_corpus(shared_data):
    maps, problems = discover_maps(shared_data / "maps")
    assert problems == []
    rel = {p.relative_to(shared_data / "maps").as_posix() for p in maps}
    # every YAML is a map; images are found once (through their YAML when one names them)
    assert len([r for r in rel if r.endswith(".yaml")]) == 72
    assert "utexas_gdc_large/2/2_original.pgm" in rel     # no YAML names it
    assert "utexas_gdc_large/2/2.pgm" not in rel          # 2.yaml names it
    assert "ros_whill_arc/gmapping.pgm" not in rel        # named by an absolute path
    assert "nanobot/new_maps/karto.pgm" not in rel
    assert "nanobot/new_maps/gmapping_processed.pgm" in rel
    assert len(rel) == 117
    assert np.all([p.exists() for p in maps])


def test_symlink_loops_fifos_and_broken_links_are_reported_not_fatal(tmp_path):
    good = _pgm(tmp_path / "good.pgm")
    (tmp_path / "a.pgm").symlink_to(tmp_path / "b.pgm")
    (tmp_path / "b.pgm").symlink_to(tmp_path / "a.pgm")
    (tmp_path / "gone.pgm").symlink_to(tmp_path / "nowhere.pgm")
    os.mkfifo(tmp_path / "pipe.yaml")  # reading it would block for ever
    maps, problems = discover_maps([tmp_path, tmp_path / "a.pgm"])
    assert [p.name for p in maps] == ["a.pgm", "b.pgm", "gone.pgm", "good.pgm", "pipe.yaml"]
    # found in a folder, the loop and the FIFO are maps whose loading fails (never blocks);
    # named, the loop is a problem
    reasons = {Path(p).name: r for p, r in problems}
    assert reasons == {"a.pgm": "cannot read: Too many levels of symbolic links"}
    with pytest.raises(slamq.MapError, match="not a regular file"):
        load_map(tmp_path / "pipe.yaml")
    assert load_map(good).shape == (2, 2)


def test_eval_and_batch_discover_the_same_maps(tmp_path):
    """`slamq eval DIR` and `slamq batch DIR` walk folders with one function
    (slamq.sources.walk): the same maps, whatever the tree holds."""
    from slamq.batch import discover_runs

    run = tmp_path / "gmapping" / "office" / "1"
    run.mkdir(parents=True)
    _pgm(run / "map.pgm")
    _yaml(run / "map.yaml", "map.pgm")
    for i in (10, 20, 30):  # snapshots beside the final map: frames, not maps
        _pgm(run / f"map_{i:05d}.pgm")
    frames = tmp_path / "hector" / "office" / "1"
    frames.mkdir(parents=True)
    for i in (10, 20):  # only snapshots: the last one is the map
        _pgm(frames / f"mapping_{i:05d}.png")
    flat = tmp_path / "flat"
    flat.mkdir()
    _pgm(flat / "karto_map.pgm")  # a bare image
    _pgm(flat / "4_07_2022.pgm")  # a dated name is not a snapshot
    _yaml(flat / "office_ground_truth.yaml", "gt.pgm")
    _pgm(flat / "gt.pgm")
    (flat / "config.yaml").write_text("rate: 10\n")  # not a map YAML
    (flat / "run.bag").write_bytes(b"#ROSBAG V2.0\n")  # bags inside folders are not maps
    bag2 = flat / "rosbag2"
    bag2.mkdir()
    (bag2 / "metadata.yaml").write_text("rosbag2_bagfile_information: {}\n")
    _pgm(bag2 / "inside.pgm")  # a bag folder is skipped whole
    hidden = tmp_path / ".cache"
    hidden.mkdir()
    _pgm(hidden / "h.pgm")

    maps, problems = discover_maps(tmp_path)
    assert problems == []
    runs = discover_runs(tmp_path)
    assert sorted(Path(r.map) for r in runs) == sorted(p.absolute() for p in maps)
    assert sorted(p.relative_to(tmp_path).as_posix() for p in maps) == [
        "flat/4_07_2022.pgm", "flat/karto_map.pgm", "flat/office_ground_truth.yaml",
        "gmapping/office/1/map.yaml", "hector/office/1/mapping_00020.png",
    ]


def test_a_slamq_run_output_folder_gives_each_runs_final_map(tmp_path: Path) -> None:
    """Issue 42, point 3: `slamq verdict out/` walked into each run's raw outputs and
    snapshots and the report (47 "maps" for 3 runs). A run folder gives the map its
    run.json names, an output root skips report/, sequences/ and shards/."""
    import json

    def pgm(p: Path) -> None:
        p.parent.mkdir(parents=True, exist_ok=True)
        img = np.full((8, 8), 254, np.uint8)
        img[2, 1:7] = 0
        p.write_bytes(b"P5\n8 8\n255\n" + img.tobytes())

    out = tmp_path / "out"
    (out / "runs.csv").parent.mkdir(parents=True)
    (out / "runs.csv").write_text("algorithm,outcome\n")
    finals = []
    for alg in ("rbpf", "icp", "graph"):
        run = out / alg / "default" / "seq" / "1"
        pgm(run / "out" / "finalMap.pgm")
        for k in range(3):
            pgm(run / "out" / "maps" / f"mapbuilt_{k:04d}.pgm")
        pgm(run / "map.pgm")
        (run / "map.yaml").write_text("image: map.pgm\nresolution: 0.05\n"
                                      "origin: [0, 0, 0]\nnegate: 0\n"
                                      "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
        (run / "run.json").write_text(json.dumps({"map": str(run / "map.yaml")}))
        finals.append(run / "map.yaml")
    pgm(out / "report" / "thumb.pgm")
    pgm(out / "sequences" / "seq" / "gt_map.pgm")
    pgm(out / "shards" / "x.pgm")
    found, problems = discover_maps([out])
    assert sorted(found) == sorted(finals) and problems == []
    # a failed run (no map) gives nothing, and the output folder moved still works
    failed = out / "slam" / "default" / "seq" / "1"
    failed.mkdir(parents=True)
    (failed / "run.json").write_text(json.dumps({"map": None, "outcome": "crash"}))
    pgm(failed / "out" / "partial.pgm")
    moved = tmp_path / "moved"
    out.rename(moved)
    found, _ = discover_maps([moved])
    assert sorted(p.relative_to(moved) for p in found) == sorted(
        p.relative_to(out) for p in finals)
