"""slamq.batch: run discovery, evaluate_many, resumable results files, summarize, the CLI."""

from __future__ import annotations

import json
import math
import os
import shutil
import signal
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pandas as pd
import pytest
from conftest import slamq_env  # noqa: E402
from hypothesis import given, settings
from hypothesis import strategies as st

import slamq
from slamq.batch import Run, discover_runs, evaluate_many, read_manifest
from slamq.batch.records import content_hash
from slamq.cli import main as cli_main
from slamq.results import read_results, summarize
from slamq.results.formats import journal_path
from slamq.results.store import ResultsFile


def _core_available() -> bool:
    try:
        from slamq import _core  # noqa: F401
    except ImportError:
        return False
    return True


needs_core = pytest.mark.skipif(not _core_available(), reason="slamq._core is not built")


def room(n: int = 40, seed: int = 0, walls: int = 3) -> np.ndarray:
    """A small map_saver-style map: free room, a few walls, unknown outside."""
    rng = np.random.default_rng(seed)
    img = np.full((n, n), 205, np.uint8)
    img[4:-4, 4:-4] = 254
    img[4, 4:-4] = img[-5, 4:-4] = 0
    img[4:-4, 4] = img[4:-4, -5] = 0
    for _ in range(walls):
        r, c = rng.integers(8, n - 8, 2)
        img[r, c : c + rng.integers(2, 6)] = 0
    return img


def write_map(path: Path, img: np.ndarray, *, yaml: bool = True) -> Path:
    """Write ``img`` as PGM (+ YAML when asked); returns the map path (YAML or PGM)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    pgm = path.with_suffix(".pgm")
    assert cv2.imwrite(str(pgm), img)
    if not yaml:
        return pgm
    y = path.with_suffix(".yaml")
    y.write_text(
        f"image: {pgm.name}\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n"
    )
    return y


def write_tum(path: Path, xy: np.ndarray, t0: float = 0.0) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    lines = [f"{t0 + i:.3f} {x:.6f} {y:.6f} 0 0 0 0 1" for i, (x, y) in enumerate(xy)]
    path.write_text("\n".join(lines) + "\n")
    return path


# --------------------------------------------------------------------------- discovery


def test_run_layout_with_trajectories_spaces_and_odd_names(tmp_path: Path) -> None:
    root = tmp_path / "runs"
    gt_xy = np.c_[np.linspace(0, 5, 20), np.sin(np.linspace(0, 3, 20))]
    write_map(root / "gmapping" / "office floor" / "run 1" / "map", room(seed=1))
    write_tum(root / "gmapping" / "office floor" / "run 1" / "trajectory.txt", gt_xy + 0.01)
    write_map(root / "gmapping" / "office floor" / "run 2" / "map", room(seed=2))
    write_tum(root / "gmapping" / "office floor" / "run 2" / "poses.tum", gt_xy - 0.01)
    write_tum(root / "gmapping" / "office floor" / "groundtruth.txt", gt_xy)
    write_map(root / "hector_ü" / "lab,1" / "r#3" / "final", room(seed=3), yaml=False)
    # snapshots beside the final map are animation frames, not runs
    for i in range(3):
        write_map(root / "hector_ü" / "lab,1" / "r#3" / f"map_{i:04d}", room(seed=i), yaml=False)
    # a non-map YAML, a hidden folder and a ROS 2 bag folder are ignored
    (root / "hector_ü" / "lab,1" / "r#3" / "params.yaml").write_text("rate: 5\n")
    write_map(root / ".cache" / "x" / "y" / "map", room())
    (root / "bag" / "b" / "c").mkdir(parents=True)
    (root / "bag" / "b" / "c" / "metadata.yaml").write_text("rosbag2_bagfile_information: {}\n")

    runs = discover_runs(root)
    got = [(r.algorithm, r.sequence, r.run, r.map.name) for r in runs]
    assert got == [
        ("gmapping", "office floor", "run 1", "map.yaml"),
        ("gmapping", "office floor", "run 2", "map.yaml"),
        ("hector_ü", "lab,1", "r#3", "final.pgm"),
    ]
    assert runs[0].trajectory is not None and runs[0].trajectory.name == "trajectory.txt"
    assert runs[1].trajectory is not None and runs[1].trajectory.name == "poses.tum"
    assert runs[0].groundtruth == root / "gmapping" / "office floor" / "groundtruth.txt"
    assert runs[1].groundtruth == runs[0].groundtruth
    assert runs[2].trajectory is None and runs[2].groundtruth is None


def test_flat_layout_names_and_mirrored_trajectories(tmp_path: Path) -> None:
    maps = tmp_path / "maps" / "grp" / "test_results" / "office"
    write_map(maps / "gmapping_map", room(seed=1))
    write_map(maps / "slam_toolbox_map", room(seed=2))
    write_map(maps / "gmapping_map_cropped", room(seed=3), yaml=False)
    write_map(maps / "karto_map_2", room(seed=4))
    write_map(maps / "weird name", room(seed=5), yaml=False)
    traj = tmp_path / "trajectories" / "grp" / "office"
    traj.mkdir(parents=True)
    header = "timestamp_sec,slam_x,slam_y,gt_x,gt_y\n"
    (traj / "gmapping_pose_log.csv").write_text(header + "0,0,0,0,0\n5,1,0,1,0\n10,1,1,1,1\n")
    (traj / "gmapping_cropped_pose_log.csv").write_text(header + "0,0,0,0,0\n")
    write_tum(traj / "karto.txt", np.zeros((3, 2)))

    runs = {r.algorithm: r for r in discover_runs(maps.parent)}
    assert sorted(runs) == [
        "gmapping", "gmapping_cropped", "karto", "slam_toolbox", "weird name",
    ]
    assert all(r.sequence == "office" for r in runs.values())
    assert runs["karto"].run == "2" and runs["gmapping"].run == "0"
    # the longest algorithm name owns a trajectory file
    assert runs["gmapping"].trajectory == traj / "gmapping_pose_log.csv"
    assert runs["gmapping_cropped"].trajectory == traj / "gmapping_cropped_pose_log.csv"
    # a paired pose log (slam_x and gt_x on one row) is its own ground truth
    assert runs["gmapping"].groundtruth == runs["gmapping"].trajectory
    assert runs["karto"].trajectory == traj / "karto.txt" and runs["karto"].groundtruth is None
    assert runs["slam_toolbox"].trajectory is None
    # a ground-truth map joins its sequence as algorithm "ground_truth"
    write_map(maps.parent.parent / "ground_truths" / "office_ground_truth", room(seed=6))
    found = discover_runs(maps.parent.parent)
    gt = [r for r in found if r.algorithm == "ground_truth"]
    assert [(r.sequence, r.map.name) for r in gt] == [("office", "office_ground_truth.yaml")]
    assert len(found) == 6


def test_single_map_file_and_missing_source(tmp_path: Path) -> None:
    m = write_map(tmp_path / "lab" / "cartographer_map", room())
    (r,) = discover_runs(m)
    assert (r.algorithm, r.sequence, r.run) == ("cartographer", "lab", "0")
    with pytest.raises(slamq.MapError, match="no such file"):
        discover_runs(tmp_path / "nope")
    assert discover_runs([m, m, Run(m, "cartographer", "lab")]) == [r]


def test_manifest(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    d = tmp_path / "my batch"
    write_map(d / "maps" / "a b", room(seed=1))
    write_tum(d / "est 1.txt", np.zeros((3, 2)))
    (d / "runs.csv").write_text(
        "# algorithm, sequence, run, map, trajectory, groundtruth\n"
        "algorithm, sequence, run, map, trajectory, groundtruth\n"
        "gmapping, hall, 1, maps/a b.yaml, est 1.txt, /abs/gt.txt\n"
        ", , , maps/a b.yaml,,\n"
        "\n"
        'hector, hall, 2, "maps/missing, really.pgm",,\n'
    )
    runs = read_manifest(d / "runs.csv")
    assert [(r.algorithm, r.sequence, r.run) for r in runs] == [
        ("gmapping", "hall", "1"), ("a b", "maps", "0"), ("hector", "hall", "2"),
    ]
    assert runs[0].map == d / "maps" / "a b.yaml"
    assert runs[0].trajectory == d / "est 1.txt"
    assert runs[0].groundtruth == Path("/abs/gt.txt")
    assert runs[1].trajectory is None and runs[1].groundtruth is None
    assert runs[2].map == d / "maps" / "missing, really.pgm"  # kept: the batch reports it
    assert discover_runs(d / "runs.csv") == runs
    # a manifest given by a relative path, CRLF line ends: blank sequence = map's folder
    (d / "crlf.csv").write_bytes(b"map,sequence\r\nmaps/../est 1.txt,\r\n")
    monkeypatch.chdir(d)
    (r,) = read_manifest("crlf.csv")
    assert (r.algorithm, r.sequence, r.run) == ("est 1", "my batch", "0")


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("algorithm,sequence\na,b\n", "no 'map' column"),
        ("", "empty manifest"),
        ("map,map\nx.pgm,y.pgm\n", "duplicate column"),
        ("map,run\nx.pgm,1,extra\n", "line 2: 3 fields"),
        ("map,run\n,1\n", "line 2: empty 'map'"),
        ("map,run\nx.pgm,1\nx.pgm,1\n", "line 3: .*already listed on line 2"),
    ],
)
def test_bad_manifest(tmp_path: Path, text: str, match: str) -> None:
    p = tmp_path / "m.csv"
    p.write_text(text)
    with pytest.raises(slamq.MapError, match=match) as info:
        discover_runs(p)
    assert str(p) in str(info.value)


# --------------------------------------------------------------------------- results files


def _rec(i: int, **kw: object) -> dict:
    rec = {"map": f"m{i}.pgm", "algorithm": "a", "sequence": "s", "run": str(i),
           "corners": i, "proportion": float("nan"), "error": None}
    rec.update(kw)
    return rec


@pytest.mark.parametrize("name", ["r.jsonl", "r.parquet"])
def test_results_file_roundtrip_and_torn_line(tmp_path: Path, name: str) -> None:
    path = tmp_path / name
    with ResultsFile(path) as rf:
        rf.append([_rec(0), _rec(1)])
        rf.append([_rec(2)])
    df = read_results(path)
    assert df["corners"].tolist() == [0, 1, 2]
    assert df["proportion"].isna().all()
    # a kill -9 in the middle of a write leaves a torn last line in the append file
    torn = path if name.endswith(".jsonl") else journal_path(path)
    with open(torn, "a") as fh:
        fh.write('{"map": "m3.pgm", "algorithm": "a", "seq')
    assert read_results(path)["corners"].tolist() == [0, 1, 2]
    with ResultsFile(path) as rf:  # resuming cuts the torn line off, then appends
        assert len(rf) == 3
        rf.append([_rec(3), _rec(1, corners=10)])  # a re-evaluated run replaces its row
    df = read_results(path)
    assert df["corners"].tolist() == [0, 2, 3, 10]
    assert not journal_path(path).exists()
    if name.endswith(".jsonl"):
        lines = path.read_text().splitlines()
        assert len(lines) == 4 and all(json.loads(line) for line in lines)


def test_read_results_errors(tmp_path: Path) -> None:
    with pytest.raises(slamq.ParamError, match="unknown results format '.txt'"):
        read_results(tmp_path / "r.txt")
    with pytest.raises(slamq.MapError, match="no such results file"):
        read_results(tmp_path / "r.csv")
    with pytest.raises(slamq.MapError, match="no such results file"):
        read_results(tmp_path / "r.parquet")
    mid = tmp_path / "mid.jsonl"
    mid.write_text('{"map": "a", "run": "0"}\n{"map": garbage}\n{"map": "b", "run": "0"}\n')
    with pytest.raises(slamq.MapError, match="mid.jsonl: line 2: not a JSON record"):
        read_results(mid)
    bad = tmp_path / "bad.parquet"
    bad.write_bytes(b"PAR1 not really")
    with pytest.raises(slamq.MapError, match="bad.parquet: not a readable Parquet"):
        read_results(bad)


# --------------------------------------------------------------------------- summarize


def test_summarize_by_hand() -> None:
    recs = [
        # a/s: corners 10, 12, 17 -> mean 13, sample std sqrt(((-3)^2 + (-1)^2 + 4^2) / 2)
        {"algorithm": "a", "sequence": "s", "run": "1", "corners": 10, "ate_rmse": 0.2,
         "occupied_fraction": 0.5, "error": None},
        {"algorithm": "a", "sequence": "s", "run": "2", "corners": 12, "ate_rmse": 0.4,
         "occupied_fraction": 0.25, "error": None},
        {"algorithm": "a", "sequence": "s", "run": "3", "corners": 17, "ate_rmse": None,
         "occupied_fraction": 0.0, "error": None},
        {"algorithm": "a", "sequence": "s", "run": "4", "corners": None, "ate_rmse": None,
         "occupied_fraction": None, "error": "x.pgm: broken"},
        {"algorithm": "b", "sequence": "s", "run": "1", "corners": 7, "ate_rmse": None,
         "occupied_fraction": 0.1, "error": None},
    ]
    s = summarize(recs)
    assert s[["algorithm", "sequence", "n", "failed", "ate_runs"]].values.tolist() == [
        ["a", "s", 3, 1, 2], ["b", "s", 1, 0, 0],
    ]
    a = s.iloc[0]
    assert a["corners_mean"] == 13.0
    assert a["corners_std"] == pytest.approx(math.sqrt(13.0))
    assert a["ate_rmse_mean"] == pytest.approx(0.3)
    assert a["ate_rmse_std"] == pytest.approx(math.sqrt(0.02))  # (0.1^2 + 0.1^2) / 1
    assert a["occupied_fraction_mean"] == pytest.approx(0.25)
    assert math.isnan(s.iloc[1]["corners_std"])  # one run: no sample std
    pop = summarize(pd.DataFrame(recs), ddof=0).iloc[0]
    assert pop["corners_std"] == pytest.approx(math.sqrt(26.0 / 3.0))
    assert pop["ate_rmse_std"] == pytest.approx(0.1)
    # no trajectory anywhere: no ATE columns
    assert "ate_rmse_mean" not in summarize([{**recs[4], "ate_rmse": None}]).columns


# --------------------------------------------------------------------------- evaluate_many


def _tree(root: Path, n: int, *, size: int = 40) -> list[Path]:
    paths = []
    for i in range(n):
        alg = ("gmapping", "karto")[i % 2]
        paths.append(write_map(root / alg / "hall" / f"run{i:03d}" / "map", room(size, seed=i)))
    return paths


@needs_core
def test_evaluate_many_matches_evaluate_in_order(tmp_path: Path) -> None:
    paths = _tree(tmp_path / "runs", 7)
    recs = list(evaluate_many(tmp_path / "runs", threads=2, chunk_size=2, min_area=2))
    assert [r["map"] for r in recs] == [str(p) for p in sorted(paths)]
    for rec in recs:
        q = slamq.evaluate(rec["map"], min_area=2).to_dict()
        q.pop("curve")
        assert {k: rec[k] for k in q} == q
        assert rec["error"] is None and rec["hash"] == content_hash(rec["map"])
        assert rec["seconds"] > 0 and rec["ate_rmse"] is None
    # thread count, chunk size and executor do not change the records
    with ThreadPoolExecutor(3) as pool:
        other = list(evaluate_many(tmp_path / "runs", executor=pool, chunk_size=5, min_area=2))
    strip = [{k: v for k, v in r.items() if k != "seconds"} for r in recs]
    assert [{k: v for k, v in r.items() if k != "seconds"} for r in other] == strip


@needs_core
def test_corrupt_map_in_the_middle(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    paths = _tree(tmp_path / "runs", 5)
    bad = paths[2].with_suffix(".pgm")
    bad.write_bytes(bad.read_bytes()[:30])  # truncated image
    gone = tmp_path / "runs" / "karto" / "hall" / "run009"
    gone.mkdir()
    (gone / "map.yaml").write_text("image: missing.pgm\nresolution: 0.05\n")
    recs = list(evaluate_many(tmp_path / "runs", threads=2, chunk_size=1))
    assert len(recs) == 6
    errors = {Path(r["map"]).parent.name: r["error"] for r in recs if r["error"]}
    assert sorted(errors) == ["run002", "run009"]
    assert str(paths[2]) in errors["run002"]
    assert "missing.pgm" in errors["run009"]
    assert all(r["corners"] is not None for r in recs if not r["error"])

    out = tmp_path / "r.jsonl"
    rc = cli_main(["batch", str(tmp_path / "runs"), "--out", str(out), "--no-progress", "-q"])
    err = capsys.readouterr().err
    assert rc == 2
    lines = [line for line in err.splitlines() if line.startswith("slamq: error:")]
    assert len(lines) == 2 and any(str(paths[2]) in line for line in lines)
    assert len(read_results(out)) == 6


@needs_core
def test_fifo_in_a_manifest_is_a_failed_row_not_a_hang(tmp_path: Path) -> None:
    import os

    good = write_map(tmp_path / "good", room())
    os.mkfifo(tmp_path / "pipe.pgm")
    os.mkfifo(tmp_path / "pipe.yaml")
    (tmp_path / "m.csv").write_text(
        f"run,map\n1,pipe.pgm\n2,pipe.yaml\n3,{good.name}\n")
    import threading

    got: list = []
    worker = threading.Thread(  # daemon: a hang fails the test instead of stalling pytest
        target=lambda: got.extend(evaluate_many(tmp_path / "m.csv", threads=2)), daemon=True)
    worker.start()
    worker.join(timeout=60)
    assert not worker.is_alive(), "evaluate_many hangs on a FIFO"
    recs = got
    assert [r["run"] for r in recs] == ["1", "2", "3"]
    assert "pipe.pgm" in recs[0]["error"] and "not a regular file" in recs[0]["error"]
    assert "pipe.yaml" in recs[1]["error"] and "not a regular file" in recs[1]["error"]
    assert recs[2]["error"] is None and recs[2]["hash"] == content_hash(good)


@needs_core
def test_resume_skips_done_and_redoes_changed(tmp_path: Path) -> None:
    paths = _tree(tmp_path / "runs", 6)
    out = tmp_path / "r.parquet"
    first = list(evaluate_many(tmp_path / "runs", out=out, threads=2, chunk_size=4))
    assert len(first) == 6
    calls: list[tuple[int, int]] = []
    skipped = evaluate_many(tmp_path / "runs", out=out, progress=lambda *a: calls.append(a))
    assert list(skipped) == []
    assert calls == [(i, 6) for i in range(7)]  # skipped maps count as progress
    write_map(paths[1].with_suffix(""), room(seed=99))  # new content: evaluated again
    again = list(evaluate_many(tmp_path / "runs", out=out, threads=2))
    assert [r["map"] for r in again] == [str(paths[1])]
    df = read_results(out)
    assert len(df) == 6 and not df.duplicated(["algorithm", "sequence", "run", "map"]).any()
    assert df.set_index("map").loc[str(paths[1]), "hash"] == content_hash(paths[1])
    # other parameters: everything again, still one row per run
    with pytest.warns(UserWarning, match="other settings"):
        assert len(list(evaluate_many(tmp_path / "runs", out=out, min_area=3))) == 6
    df = read_results(out)
    assert len(df) == 6 and (df["param_min_area"] == 3).all()


@needs_core
def test_resume_from_another_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Paths in the results file are absolute: the same batch spelt from another working
    folder resumes (no duplicate rows), and the report can reopen the maps from anywhere."""
    _tree(tmp_path / "runs", 3)
    out = tmp_path / "r.jsonl"
    monkeypatch.chdir(tmp_path)
    first = list(evaluate_many("runs", out="r.jsonl"))
    assert len(first) == 3 and all(Path(r["map"]).is_absolute() for r in first)
    monkeypatch.chdir(tmp_path / "runs")
    assert list(evaluate_many("../runs", out=out)) == []
    assert list(evaluate_many(tmp_path / "runs", out=out)) == []
    assert len(read_results(out)) == 3


@needs_core
def test_other_settings_are_never_mixed_silently(tmp_path: Path) -> None:
    _tree(tmp_path / "runs", 4)
    out = tmp_path / "r.jsonl"
    assert len(list(evaluate_many(tmp_path / "runs", out=out))) == 4
    with pytest.warns(UserWarning, match=r"4 stored record\(s\) .*other settings "
                      r"\(min_area: 1, 3\); this batch evaluates its maps again, but 3 "
                      r"record\(s\) of maps outside this batch keep theirs"):
        again = list(evaluate_many(discover_runs(tmp_path / "runs")[:1], out=out, min_area=3))
    assert [r["param_min_area"] for r in again] == [3]
    df = read_results(out)
    assert len(df) == 4 and sorted(df["param_min_area"]) == [1, 1, 1, 3]
    with pytest.warns(UserWarning, match=r"different settings \(min_area: 1, 3\)"):
        summarize(df)
    from slamq.report import build_report

    site = build_report(df, tmp_path / "site", details="gallery", gifs=False)
    assert 'id="mixed-settings"' in site.read_text(encoding="utf-8")
    # the whole batch again with the new setting: one setting left, no warning
    with pytest.warns(UserWarning, match="this batch evaluates its maps again$"):
        assert len(list(evaluate_many(tmp_path / "runs", out=out, min_area=3))) == 3
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert (summarize(out)["n"] == 2).all()
        assert list(evaluate_many(tmp_path / "runs", out=out, min_area=3)) == []


@needs_core
def test_report_draws_trajectories_with_the_batch_ate_options(tmp_path: Path) -> None:
    """A restarted log scored with ate_unsorted="last": the report reads it the same way."""
    from slamq.report import build_report

    run = tmp_path / "runs" / "gmapping" / "hall" / "r1"
    write_map(run / "map", room(40))
    t = np.arange(20.0)
    gt_xy = np.c_[0.5 + 0.05 * t, 1.0 + 0.2 * np.sin(t / 3)]
    write_tum(run.parent / "groundtruth.txt", gt_xy)
    est = [f"{100 + i} 9 9 0 0 0 0 1" for i in range(3)]  # the log before a restart
    est += [f"{ti:.3f} {x + 0.01:.6f} {y:.6f} 0 0 0 0 1" for ti, (x, y) in zip(t, gt_xy)]
    (run / "trajectory.txt").write_text("\n".join(est) + "\n")
    out = tmp_path / "r.jsonl"
    (rec,) = evaluate_many(tmp_path / "runs", out=out, ate_unsorted="last", ate_align="none")
    assert rec["ate_error"] is None and rec["ate_n"] == 20
    assert rec["ate_rmse"] == pytest.approx(0.01)
    site = build_report(out, tmp_path / "site", gifs=False)
    page = next((site.parent / "maps").glob("*.html")).read_text(encoding="utf-8")
    assert "not drawn" not in page and "_traj.png" in page
    assert "20 poses, ATE RMSE 0.01 m" in page


@needs_core
def test_batch_over_shared_data_like_tree(tmp_path: Path, test_data: Path) -> None:
    """slam_comparison_tools' flat layout, with its trajectories in the mirrored tree."""
    src = test_data / "slam_comparison_tools" / "test_results" / "office"
    maps = tmp_path / "data" / "maps" / "slam_comparison_tools" / "test_results" / "office"
    shutil.copytree(src, maps)
    traj = tmp_path / "data" / "trajectories" / "slam_comparison_tools" / "office"
    traj.mkdir(parents=True)
    t = np.arange(0, 60, 5.0)
    xy = np.c_[np.cos(t / 20), np.sin(t / 20)] * 3
    noise = np.random.default_rng(0).normal(0, 0.05, xy.shape)
    with open(traj / "gmapping_pose_log.csv", "w") as fh:
        fh.write("timestamp_sec,slam_x,slam_y,gt_x,gt_y\n")
        for ti, (gx, gy), (nx, ny) in zip(t, xy, noise):
            fh.write(f"{ti:.2f},{gx + nx},{gy + ny},{gx},{gy}\n")
    out = tmp_path / "out" / "results.parquet"
    rc = cli_main(["batch", str(maps.parent), "--out", str(out), "--no-progress", "-q",
                   "--threads", "2"])
    assert rc == 0
    df = read_results(out)
    assert sorted(df["algorithm"]) == [
        "cartographer", "gmapping", "lidar_rtabmap", "rgbd_rtabmap", "slam_toolbox",
    ]
    assert (df["sequence"] == "office").all() and df["error"].isna().all()
    g = df.set_index("algorithm").loc["gmapping"]
    from slamq.metrics.ate import ate
    from slamq.sources.trajectories import load_trajectory

    log = traj / "gmapping_pose_log.csv"
    expected = ate(
        load_trajectory(log, columns={"t": "timestamp_sec", "x": "gt_x", "y": "gt_y"}),
        load_trajectory(log, columns={"t": "timestamp_sec", "x": "slam_x", "y": "slam_y"}),
    )
    assert g["ate_rmse"] == pytest.approx(expected.rmse, rel=1e-12)
    assert g["ate_n"] == len(t)
    assert df.set_index("algorithm")["ate_rmse"].drop("gmapping").isna().all()
    s = summarize(out)
    assert s.set_index("algorithm").loc["gmapping", "ate_rmse_mean"] == pytest.approx(
        expected.rmse
    )
    q = slamq.evaluate(maps / "gmapping_map.yaml")
    assert g["corners"] == q.corners and g["enclosed_areas"] == q.enclosed_areas


@needs_core
def test_cli_summary_and_bad_input(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    _tree(tmp_path / "runs", 4)
    out = tmp_path / "r.jsonl"
    assert cli_main(["batch", str(tmp_path / "runs"), "-o", str(out), "--no-progress"]) == 0
    printed = capsys.readouterr().out
    assert "gmapping" in printed and "karto" in printed
    assert cli_main(["summary", str(out), "--csv", str(tmp_path / "s.csv")]) == 0
    table = capsys.readouterr().out
    assert "hall" in table and "±" in table
    s = pd.read_csv(tmp_path / "s.csv")
    assert s["n"].tolist() == [2, 2]
    assert cli_main(["batch", str(tmp_path / "nope"), "-o", str(out)]) == 2
    assert "nope: no such file" in capsys.readouterr().err
    assert cli_main(["batch", str(tmp_path / "runs"), "-o", str(tmp_path / "r.txt")]) == 2
    assert "unknown results format" in capsys.readouterr().err
    empty = tmp_path / "empty"
    empty.mkdir()
    assert cli_main(["batch", str(empty), "-o", str(tmp_path / "e.jsonl")]) == 2
    assert "no map found" in capsys.readouterr().err


def test_bad_parameters_fail_before_any_work(tmp_path: Path) -> None:
    with pytest.raises(slamq.ParamError, match="threads"):
        evaluate_many(tmp_path, threads=0)
    with pytest.raises(slamq.ParamError, match="chunk_size"):
        evaluate_many(tmp_path, chunk_size=-1)
    with pytest.raises(slamq.ParamError, match="sweep_step"):
        evaluate_many(tmp_path, sweep_step=0)
    with pytest.raises(slamq.ParamError, match="unknown parameter"):
        evaluate_many(tmp_path, no_such_param=1)
    with pytest.raises(slamq.ParamError, match="executor"):
        evaluate_many(tmp_path, executor="rayon")
    with pytest.raises(slamq.ParamError, match="r.csv: unknown results format"):
        evaluate_many(tmp_path / "no such folder", out=tmp_path / "r.csv")


# --------------------------------------------------------------------------- kill -9


def _journal_lines(out: Path) -> int:
    target = journal_path(out) if out.suffix == ".parquet" else out
    try:
        return target.read_bytes().count(b"\n")
    except FileNotFoundError:
        return 0


@needs_core
@pytest.mark.parametrize("name", ["results.parquet", "results.jsonl"])
def test_resume_after_sigkill(tmp_path: Path, name: str) -> None:
    n = 60
    for i in range(n):
        write_map(tmp_path / "runs" / f"alg{i % 3}" / "seq" / f"r {i:02d}" / "map",
                  room(64, seed=i, walls=6))
    out = tmp_path / name
    env = slamq_env()
    # --verify runs the slow reference too, so the batch takes seconds and is killed mid-way
    cmd = [sys.executable, "-m", "slamq", "batch", str(tmp_path / "runs"), "--out",
           str(out), "--chunk-size", "1", "--threads", "1", "--verify", "--no-progress", "-q"]
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 60
    while _journal_lines(out) < 5 and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.005)
    proc.send_signal(signal.SIGKILL)
    proc.communicate()
    assert proc.returncode == -signal.SIGKILL
    done_before = _journal_lines(out)
    assert 5 <= done_before < n, "the batch was not killed mid-way"
    if name.endswith(".parquet"):
        assert not out.exists()  # never half-written: only the journal holds the rows
    partial = read_results(out)
    assert len(partial) >= 5 and not partial.duplicated("map").any()

    rerun = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=300)
    assert rerun.returncode == 0, rerun.stderr
    assert f"already in {out}" in rerun.stderr
    evaluated = int(rerun.stderr.split("slamq batch: ")[1].split(" map(s)")[0])
    assert evaluated == n - len(partial)
    df = read_results(out)
    expected = sorted(str(p) for p in (tmp_path / "runs").rglob("map.yaml"))
    assert sorted(df["map"]) == expected  # no missing row
    assert not df.duplicated(["algorithm", "sequence", "run", "map"]).any()  # no duplicate
    assert df["error"].isna().all()
    assert not journal_path(out).exists()
    # the rows written before the kill are the same as a fresh evaluation's
    first = df.set_index("map").loc[partial["map"]]
    assert first["corners"].tolist() == partial["corners"].tolist()


def test_symlinked_folders_are_followed_once(tmp_path: Path) -> None:
    real = tmp_path / "store" / "run 7"
    write_map(real / "map", room())
    root = tmp_path / "runs"
    (root / "gmapping" / "hall").mkdir(parents=True)
    (root / "gmapping" / "hall" / "r7").symlink_to(real, target_is_directory=True)
    (root / "gmapping" / "hall" / "r7-again").symlink_to(real, target_is_directory=True)
    (root / "gmapping" / "loop").symlink_to(root, target_is_directory=True)  # a cycle
    runs = discover_runs(root)
    assert [(r.algorithm, r.sequence, r.run) for r in runs] == [("gmapping", "hall", "r7")]
    assert runs[0].map == root / "gmapping" / "hall" / "r7" / "map.yaml"


def test_discovery_is_linear_in_the_number_of_maps(tmp_path: Path) -> None:
    """3,000 maps and their trajectories in one flat folder: each map used to filter the
    whole folder for its trajectory and ground truth (quadratic: about 20 s here)."""
    seq = tmp_path / "hall"
    seq.mkdir()
    pgm = cv2.imencode(".pgm", room(20, walls=0))[1].tobytes()
    n = 3000
    for i in range(n):
        (seq / f"alg{i}_map.pgm").write_bytes(pgm)
        (seq / f"alg{i}_traj.txt").write_text("0 0 0 0 0 0 0 1\n")
    (seq / "hall_groundtruth.txt").write_text("0 0 0 0 0 0 0 1\n")
    t0 = time.perf_counter()
    runs = discover_runs(tmp_path)
    seconds = time.perf_counter() - t0
    assert len(runs) == n
    assert all(r.trajectory == seq / f"{r.algorithm}_traj.txt" for r in runs)
    assert all(r.groundtruth == seq / "hall_groundtruth.txt" for r in runs)
    assert seconds < 4.0, f"discovering {n} maps took {seconds:.1f} s"


@needs_core
def test_batch_then_report(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    import argparse

    from slamq.cli import build_parser

    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    if "report" not in sub.choices:
        pytest.skip("the report command is not part of this build")
    for alg in ("gmapping", "karto"):
        write_map(tmp_path / "maps" / "hall" / f"{alg}_map", room(32, seed=len(alg)))
    site = tmp_path / "site"
    rc = cli_main(["batch", str(tmp_path / "maps"), "--report", str(site), "--no-progress",
                   "-q"])
    assert rc == 0, capsys.readouterr().err
    assert (site / "results.parquet").is_file()  # the default --out beside the report
    assert (site / "index.html").is_file()
    assert sorted(read_results(site / "results.parquet")["algorithm"]) == ["gmapping", "karto"]


def test_shipped_fixtures_find_their_pose_logs(test_data: Path) -> None:
    """tests/data keeps maps in <group>/ and trajectories in trajectories/<group>/."""
    runs = {r.algorithm: r for r in discover_runs(test_data / "slam_comparison_tools")}
    assert runs["ground_truth"].sequence == "office"
    logs = test_data / "trajectories" / "slam_comparison_tools" / "office"
    for alg in ("cartographer", "gmapping", "lidar_rtabmap", "rgbd_rtabmap", "slam_toolbox"):
        assert runs[alg].trajectory == (logs / f"{alg}_pose_log.csv").resolve()
        assert runs[alg].groundtruth == runs[alg].trajectory


def test_manifest_pairs_a_paired_pose_log_and_counts_every_map_without_ate(
        test_data: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A manifest row whose trajectory is a paired pose log (estimate and ground truth in
    one file, as slam_comparison_tools ships) gets the ATE `slamq ate LOG.csv` prints, and
    the batch's last line counts every evaluated map without ATE, with the reason."""
    from slamq.metrics.ate import ate
    from slamq.sources.trajectories import load_pair

    maps = test_data / "slam_comparison_tools" / "test_results" / "office"
    logs = test_data / "trajectories" / "slam_comparison_tools" / "office"
    gt_map = test_data / "slam_comparison_tools" / "ground_truths" / "office_ground_truth.yaml"
    manifest = tmp_path / "runs.csv"
    manifest.write_text(
        "algorithm,sequence,run,map,trajectory,groundtruth\n"
        f"gmapping,office,0,{maps / 'gmapping_map.yaml'},{logs / 'gmapping_pose_log.csv'},\n"
        f"cartographer,office,0,{maps / 'cartographer_map.yaml'},"
        f"{logs / 'cartographer_pose_log.csv'},\n"
        f"slam_toolbox,office,0,{maps / 'slam_toolbox_map.yaml'},,\n"   # no trajectory
        f"ground_truth,office,0,{gt_map},,\n")                           # a reference map
    runs = {r.algorithm: r for r in read_manifest(manifest)}
    assert runs["gmapping"].groundtruth == runs["gmapping"].trajectory
    assert runs["slam_toolbox"].groundtruth is None
    out = tmp_path / "r.jsonl"
    assert cli_main(["batch", str(manifest), "--out", str(out), "--no-progress", "-q"]) == 0
    recs = {r["algorithm"]: r for r in map(json.loads, out.read_text().splitlines())}
    for alg in ("gmapping", "cartographer"):
        est, gt = load_pair(logs / f"{alg}_pose_log.csv", logs / f"{alg}_pose_log.csv")
        assert recs[alg]["ate_rmse"] == pytest.approx(ate(gt, est, align="se2").rmse,
                                                      rel=1e-12)
        assert recs[alg]["ate_error"] is None
    # the same number `slamq ate LOG.csv` prints
    assert cli_main(["ate", str(logs / "gmapping_pose_log.csv")]) == 0
    printed = capsys.readouterr().out.splitlines()[-1].split()
    assert float(printed[2]) == pytest.approx(recs["gmapping"]["ate_rmse"], abs=1e-6)
    assert recs["gmapping"]["ate_rmse"] < 0.05 < recs["cartographer"]["ate_rmse"]
    # a manifest row without ground truth is counted, never "0 without ATE"
    (runs_ := manifest.with_name("more.csv")).write_text(
        "algorithm,sequence,run,map,trajectory,groundtruth\n"
        f"lidar_rtabmap,office,0,{maps / 'lidar_rtabmap_map.yaml'},"
        f"{test_data / 'trajectories' / 'NOTICE.md'},\n")  # not a pose log: no ground truth
    assert cli_main(["batch", str(manifest), str(runs_), "--out", str(tmp_path / "b.jsonl"),
                     "--no-progress", "-q"]) == 0
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert ("5 map(s) evaluated, 0 already in" in last and "0 failed, 3 without ATE "
            "(1 no ground truth, 1 no trajectory, 1 reference map)" in last), last


@needs_core
def test_ros2_bag_folder_as_a_map(tmp_path: Path) -> None:
    pytest.importorskip("rosbags")
    from _bagdata import BagWriter, bag_path, room_grid

    bag = bag_path(tmp_path, "sqlite3", "hall run")
    with BagWriter(bag, "sqlite3") as w:
        w.write("/map", "nav_msgs/msg/OccupancyGrid", w.grid(1.0, room_grid(30)))
    (run,) = discover_runs(bag)
    assert run.map == bag and run.sequence == tmp_path.name
    out = tmp_path / "r.jsonl"
    (rec,) = list(evaluate_many(bag, out=out))
    assert rec["error"] is None and rec["hash"] is not None
    assert rec["enclosed_areas"] == slamq.evaluate(bag).enclosed_areas
    assert list(evaluate_many(bag, out=out)) == []  # its files are hashed: resumable


def test_dry_run_prints_the_runs_and_warns_about_a_suspicious_layout(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """tfm_turtlebot4's maps/gmapping/default.yaml and maps/hector/hector.yaml look like
    two runs of one algorithm; --dry-run shows it and the batch says so."""
    for algo, name in (("gmapping", "default"), ("hector", "hector")):
        folder = tmp_path / "tfm" / "maps" / algo
        folder.mkdir(parents=True)
        (folder / f"{name}.pgm").write_bytes(b"P5 2 2 255\n" + bytes([0, 205, 254, 254]))
    out = tmp_path / "r.jsonl"
    assert cli_main(["batch", str(tmp_path), "--dry-run", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert text.splitlines()[1].split()[:4] == ["tfm", "maps", "gmapping", "runs"]
    assert "2 runs: 1 algorithm(s) x 1 sequence(s)" in text
    assert "are they algorithms rather than runs?" in text
    assert not out.exists()  # nothing evaluated
    assert cli_main(["batch", str(tmp_path), "--out", str(out), "--no-progress"]) == 0
    err = capsys.readouterr().err
    assert "slamq batch: 2 runs" in err and "slamq: warning: algorithm 'tfm'" in err


def test_discovery_streams_the_runs_discover_runs_lists(test_data: Path, tmp_path: Path) -> None:
    """Discovery (what a batch uses, without a list of every run) finds the same runs in the
    same order as discover_runs, with each sequence's ground-truth map even when the
    reference map comes after the runs, and says the same layout lines; a run named twice
    is kept once."""
    from slamq.batch.runs import Discovery, describe_layout

    sct = test_data / "slam_comparison_tools"
    m = tmp_path / "lab" / "cartographer_map.pgm"
    m.parent.mkdir()
    m.write_bytes(b"P5 2 2 255\n" + bytes([0, 205, 254, 254]))
    sources = [sct / "test_results", sct / "ground_truths", m, sct, m]
    listed = discover_runs(sources)
    found = Discovery(sources)
    assert list(found) == listed and list(found) == listed  # iterable again
    assert [r.gt_map for r in found] == [r.gt_map for r in listed]
    assert len(found) == len(listed) == len({r.key for r in listed})
    office = [r for r in listed if r.sequence == "office" and r.algorithm != "ground_truth"]
    assert office and all(r.gt_map is not None and "ground_truth" in r.gt_map.name
                          for r in office)
    assert found.layout_lines() == describe_layout(listed)
    assert found.layout_lines()[0].startswith(f"{len(listed)} runs: ")


def test_discovery_replays_its_walk_and_walks_again_once_closed(tmp_path: Path) -> None:
    """Iterating a Discovery gives the runs its walk found (read back from its temporary
    file, more than one chunk of them here): a map added afterwards is not among them, so
    ``len()`` stays their count; two iterations may interleave; once closed, iterating
    walks the folders again and finds the new map."""
    from slamq.batch.runs import Discovery

    Discovery.CHUNK, chunk = 3, Discovery.CHUNK
    try:
        for i in range(7):
            d = tmp_path / "algo" / "seq" / f"r{i}"
            d.mkdir(parents=True)
            (d / "map.pgm").write_bytes(b"P5 2 2 255\n" + bytes([0, 205, 254, 254]))
        found = Discovery(tmp_path)
        walked = discover_runs(tmp_path)
        extra = tmp_path / "algo" / "seq" / "r7"
        extra.mkdir()
        (extra / "map.pgm").write_bytes(b"P5 2 2 255\n" + bytes([0, 205, 254, 254]))
        assert list(found) == walked and len(found) == len(walked) == 7
        a, b = iter(found), iter(found)
        pairs = [(next(a), next(b)) for _ in range(7)]
        assert [x for x, _ in pairs] == [y for _, y in pairs] == walked
        found.close()
        assert [r.run for r in found] == [f"r{i}" for i in range(8)]
    finally:
        Discovery.CHUNK = chunk


@settings(max_examples=150, deadline=None)
@given(st.dictionaries(
    st.text(min_size=1, max_size=8),
    st.one_of(st.none(), st.booleans(), st.integers(-(2**70), 2**70), st.floats(), st.text(),
              st.floats().map(np.float64), st.integers(-5, 5).map(np.int64),
              st.lists(st.floats(), max_size=3)),
    max_size=8))
def test_a_results_line_is_the_same_with_and_without_the_plain_record_shortcut(
    rec: dict[str, Any],
) -> None:
    """A record of plain values is dumped without a json_value call per value; the line is
    the one json_value gives (NaN and infinities null, numpy scalars numbers)."""
    from slamq.results.columns import json_value
    from slamq.results.formats import dumps_record as _dumps

    want = json.dumps({k: json_value(v) for k, v in rec.items()}, allow_nan=False) + "\n"
    assert _dumps(rec) == want


def _room_maps(folder: Path, n: int) -> Path:
    for i in range(n):
        img = np.full((40, 40), 254, np.uint8)
        img[5 + i % 7 : 25, 8:30] = 0
        img[30:35, :] = 205
        cv2.imwrite(str(folder / f"algo{i}_map.pgm"), img)
    return folder


def test_batch_workers_are_adopted_kept_and_reused(tmp_path: Path) -> None:
    """A local batch runs its maps on worker threads the core adopted (no second thread per
    map), keeps them for the next batch of the same thread count instead of starting new
    ones (the core keeps a few KB per adopted thread), and gives the records of
    ``slamq.evaluate``."""
    import threading

    from slamq import _core

    _room_maps(tmp_path, 6)
    names: set[str] = set()
    for _ in range(4):
        recs = list(evaluate_many(tmp_path, threads=2))
        names |= {t.name for t in threading.enumerate() if t.name.startswith("slamq-batch-2")}
        for r in recs:
            q = slamq.evaluate(r["map"], threads=1)
            assert (r["occupied"], r["corners"], r["enclosed_areas"]) == (
                q.occupied, q.corners, q.enclosed_areas)
    assert 1 <= len(names) <= 2  # the same two workers every time
    with ThreadPoolExecutor(1) as ex:  # what an adopted thread does, in a fresh thread
        first, again = ex.submit(_core.adopt_thread).result(), ex.submit(
            _core.adopt_thread).result()
        img = cv2.imread(str(tmp_path / "algo3_map.pgm"), cv2.IMREAD_GRAYSCALE)
        one, every = ex.submit(slamq.evaluate, img, threads=1).result(), ex.submit(
            slamq.evaluate, img).result()
    assert (first, again) == (True, False)
    assert one == every == slamq.evaluate(img, threads=1)


@pytest.mark.skipif(not hasattr(os, "fork"), reason="os.fork (POSIX)")
def test_a_forked_child_starts_its_own_batch_workers(tmp_path: Path) -> None:
    """The kept workers do not exist in a forked child: its batch makes new ones instead of
    waiting for threads that are not there."""
    _room_maps(tmp_path, 3)
    script = (
        "import os, sys\n"
        "from slamq.batch import evaluate_many\n"
        f"src = {str(tmp_path)!r}\n"
        "assert len(list(evaluate_many(src, threads=2))) == 3\n"
        "pid = os.fork()\n"
        "if pid == 0:\n"
        "    ok = len(list(evaluate_many(src, threads=2))) == 3\n"
        "    os._exit(0 if ok else 3)\n"
        "_, status = os.waitpid(pid, 0)\n"
        "print(os.waitstatus_to_exitcode(status))\n"
    )
    proc = subprocess.run([sys.executable, "-W", "ignore", "-c", script], env=slamq_env(),
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.split()[-1] == "0", proc.stderr[-2000:]


def test_discovery_walks_again_when_its_temporary_file_cannot_be_written(
    tmp_path: Path,
) -> None:
    """A disk that takes no more bytes (here a file size limit of 1 KB, whose writes then
    fail with EFBIG) costs the temporary file, not the batch: iterating walks the folders
    again and finds the same runs."""
    seq = tmp_path / "lab"
    seq.mkdir()
    for i in range(600):  # more than one chunk of runs: a write before the walk ends
        (seq / f"algo{i}_map.pgm").write_bytes(b"P5 2 2 255\n" + bytes([0, 205, 254, 254]))
    script = (
        "import resource, signal\n"
        "from slamq.batch.runs import Discovery, discover_runs\n"
        "signal.signal(signal.SIGXFSZ, signal.SIG_IGN)\n"
        "resource.setrlimit(resource.RLIMIT_FSIZE, (1024, 1024))\n"
        f"found = Discovery({str(tmp_path)!r})\n"
        "assert found._spill is None\n"
        "assert list(found) == discover_runs(" + repr(str(tmp_path)) + ")\n"
        "print(len(found))\n"
    )
    proc = subprocess.run([sys.executable, "-c", script], env=slamq_env(),
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert proc.stdout.split()[-1] == "600"


def test_at_most_four_kept_worker_pools(tmp_path: Path) -> None:
    """Batches with six thread counts keep the workers of the last four; the others' threads
    end once their batch is done."""
    import gc
    import threading

    _room_maps(tmp_path, 3)
    for n in (9, 10, 11, 12, 13, 14):
        assert len(list(evaluate_many(tmp_path, threads=n))) == 3
    gc.collect()
    deadline = time.monotonic() + 10
    alive: set[str] = set()
    while time.monotonic() < deadline:
        alive = {t.name.rsplit("_", 1)[0] for t in threading.enumerate()
                 if t.name.startswith("slamq-batch-") and t.is_alive()}
        if not alive & {"slamq-batch-9", "slamq-batch-10"}:
            break
        time.sleep(0.05)
    assert {"slamq-batch-11", "slamq-batch-14"} <= alive
    assert not alive & {"slamq-batch-9", "slamq-batch-10"}
