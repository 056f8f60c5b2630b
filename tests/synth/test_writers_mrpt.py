"""Real MRPT SLAM programs on rawlogs written by slamq.synth.writers (skipped without
mrpt-apps): rbpf-slam, icp-slam and graphslam-engine run by ``slamq run`` with
examples/synth_mrpt.yaml, their maps and paths collected and scored against the exact
ground truth the sequence was simulated from."""

from __future__ import annotations

import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml
from _world import make_sequence

from slamq.results import read_results
from slamq.runner import runner
from slamq.sources.mrpt import load_mrpt_grid, read_mrpt_path
from slamq.synth.writers import EPOCH, graphslam_nodes, write, write_groundtruth

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "synth_mrpt.yaml"
PROGRAMS = ("rbpf-slam", "icp-slam", "graphslam-engine")

pytestmark = pytest.mark.skipif(not all(shutil.which(p) for p in PROGRAMS),
                                reason="MRPT programs absent (apt-get install mrpt-apps)")


@pytest.fixture(scope="module")
def room(tmp_path_factory):
    """450 scans x 361 beams around most of the loop, odometry with 5% noise."""
    d = tmp_path_factory.mktemp("room")
    seq = make_sequence(450, 361, odom_noise=0.05, seed=7, name="room")
    write(seq, d, ["rawlog"])
    write_groundtruth(seq, d / "room_gt.tum")
    cv2.imwrite(str(d / "room_world.png"), seq.world.values)
    (d / "room_world.yaml").write_text(yaml.safe_dump({
        "image": "room_world.png", "resolution": seq.world.resolution,
        "origin": list(seq.world.origin), "negate": 0, "occupied_thresh": 0.65,
        "free_thresh": 0.196}))
    return d, seq


@pytest.mark.filterwarnings("ignore:room. the maps:UserWarning")  # 0.05 / 0.07 m grids
def test_three_mrpt_programs_map_a_written_rawlog(tmp_path, room):
    d, seq = room
    cfg = yaml.safe_load(EXAMPLE.read_text())
    cfg.update(output=str(tmp_path / "runs"), base_dir=str(d), report=False, timeout=120)
    result = runner.run(cfg)
    rows = {r["algorithm"]: r for r in result["rows"]}
    assert set(rows) == set(PROGRAMS)
    assert all(r["outcome"] == "ok" for r in rows.values()), \
        {a: r.get("reason") for a, r in rows.items()}
    recs = read_results(tmp_path / "runs" / "results.jsonl").set_index("algorithm")
    assert recs["error"].isna().all() and recs["ate_error"].isna().all()
    # every program's path on the sequence's clock: all poses paired with the ground truth
    n_nodes = len(graphslam_nodes(seq.odom))
    assert recs.loc["rbpf-slam", "ate_n"] == len(seq)
    assert recs.loc["icp-slam", "ate_n"] == len(seq)
    assert recs.loc["graphslam-engine", "ate_n"] == n_nodes
    # the odometry alone is off by 0.18 m RMSE (se2-aligned) here; the programs do 0.02-0.04
    assert recs.loc["rbpf-slam", "ate_rmse"] < 0.15
    assert recs.loc["icp-slam", "ate_rmse"] < 0.1
    assert recs.loc["graphslam-engine", "ate_rmse"] < 0.15
    # and the maps against the world the scans were cast in
    # (rbpf-slam's maps bend by up to ~2.5 degrees: F1 0.71-0.94 over 12 runs)
    assert recs.loc["icp-slam", "gt_f1"] > 0.8 and recs.loc["graphslam-engine", "gt_f1"] > 0.7
    assert recs.loc["rbpf-slam", "gt_f1"] > 0.5, recs["gt_f1"].to_dict()
    # the raw outputs read with slamq's MRPT adapters
    out = Path(rows["rbpf-slam"]["folder"]) / "out"
    grid = load_mrpt_grid(next(out.glob("finalMap_*_00.png")))
    assert grid.resolution == pytest.approx(0.07, rel=1e-3) and (grid.values < 50).any()
    path = read_mrpt_path(out / "log_estimated_path.txt")
    np.testing.assert_allclose(path.timestamps, EPOCH + seq.stamps, atol=1e-5)
    # rbpf-slam's frame starts at the first pose: compare the path's shape from there
    step = np.hypot(*np.diff(path.positions[:, :2], axis=0).T).sum()
    truth = np.hypot(*np.diff(seq.gt[:, :2], axis=0).T).sum()
    assert step == pytest.approx(truth, rel=0.1)
    # icp-slam logs the odometry it decoded (the actions' increments composed, from 0):
    # the sequence's odometry seen from its first pose, to the log's 6 decimals
    odo = np.loadtxt(Path(rows["icp-slam"]["folder"]) / "out" / "log_odometry_path.txt")
    c, s = np.cos(seq.odom[0, 2]), np.sin(seq.odom[0, 2])
    d = seq.odom[:, :2] - seq.odom[0, :2]
    rel = np.column_stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1],
                           np.angle(np.exp(1j * (seq.odom[:, 2] - seq.odom[0, 2])))])
    np.testing.assert_allclose(odo[:, 1:], rel, atol=2e-6)
    graph = Path(rows["graphslam-engine"]["folder"]) / "out" / "graphslam"
    assert len(read_mrpt_path(graph / "output_graph.graph")) == n_nodes
    assert (load_mrpt_grid(graph / "output_map.png").values < 50).any()
