"""End to end with MRPT's real SLAM programs (skipped without mrpt-apps): rbpf-slam with
two particle counts and icp-slam, 3 iterations each, in parallel, on the last 50 steps of
MRPT's real laser dataset (cut with rawlog-edit so the test stays short); and icp-slam on a
sequence simulated by simul-gridmap over a ground-truth map, scored against its known
trajectory."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import cv2
import numpy as np
import pytest
import yaml

from slamq.results import read_results
from slamq.runner import runner
from slamq.sources import load_map
from slamq.sources.mrpt import load_mrpt_grid, read_mrpt_path

DATASET = Path("/usr/share/mrpt/datasets/2006-01ENE-21-SENA_Telecom Faculty_one_loop_only.rawlog")
EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "mrpt.yaml"

pytestmark = pytest.mark.skipif(
    not all(shutil.which(p) for p in ("rbpf-slam", "icp-slam", "rawlog-edit"))
    or not DATASET.exists(),
    reason="MRPT programs or dataset absent (apt-get install mrpt-apps)",
)


@pytest.fixture(scope="module")
def short_rawlog(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("mrpt") / "short.rawlog"
    # the tail keeps the file's ending, which icp-slam needs (a cut head makes it assert)
    subprocess.run(["rawlog-edit", "--cut", "--from-index", "349", "-i", str(DATASET),
                    "-o", str(out)], check=True, capture_output=True, stdin=subprocess.DEVNULL,
                   timeout=60)
    return out


def test_mrpt_example_end_to_end(tmp_path: Path, short_rawlog: Path) -> None:
    cfg = yaml.safe_load(EXAMPLE.read_text())
    cfg["sequences"] = {"telecom_tail": {"input": str(short_rawlog)}}
    cfg["output"] = str(tmp_path / "runs")
    cfg["base_dir"] = str(tmp_path)
    cfg["timeout"] = 120
    # MRPT's example configs map at 0.07 m (rbpf-slam) and 0.05 m (icp-slam): said plainly
    with pytest.warns(UserWarning, match=r"telecom_tail: the maps have different "
                                         r"resolutions \(0.05 m: icp-slam#1, .*; 0.07 m: "
                                         r"rbpf-slam\[particles=20\]#1"):
        result = runner.run(cfg)
    rows = result["rows"]
    assert len(rows) == 9
    assert all(r["outcome"] == "ok" for r in rows), [(r["algorithm"], r["reason"]) for r in rows]
    assert all(r["wall"] > 0 and r["max_rss_kb"] > 10_000 for r in rows)
    summary = result["summary"].set_index("algorithm")
    assert set(summary.index) == {"rbpf-slam[particles=5]", "rbpf-slam[particles=20]",
                                  "icp-slam"}
    assert (summary["n"] == 3).all()
    assert summary["occupied_mean"].notna().all() and summary["occupied_std"].notna().all()
    # particle filters draw random samples: their maps differ between iterations
    assert summary.loc["rbpf-slam[particles=5]", "occupied_std"] > 0
    runs = tmp_path / "runs"
    assert (runs / "results.jsonl").exists() and (runs / "summary.csv").exists()
    assert "occupied_std" in (runs / "summary.csv").read_text()
    gifs = result["gifs"]
    assert len(gifs) == 6 and all(g.stat().st_size > 0 for g in gifs)  # rbpf runs' snapshots
    assert result["report"] is not None and result["report"].exists()
    # the collected files read back with slamq's MRPT adapters
    one = next(r for r in rows if r["algorithm"].startswith("rbpf"))
    png = next((Path(one["folder"]) / "out").glob("finalMap_*_00.png"))
    assert load_mrpt_grid(png).resolution == pytest.approx(0.07, rel=1e-3)
    assert len(read_mrpt_path(Path(one["folder"]) / "out" / "log_estimated_path.txt")) >= 40
    # run again: everything is resumed, nothing re-run
    again = runner.execute(cfg)
    assert all(r.get("skipped") for r in again)


# ---------------------------------------------------------------------------------------
# A sequence with a known trajectory and map: MRPT's simul-gridmap on a ground-truth map
# ---------------------------------------------------------------------------------------

DATA = Path(__file__).resolve().parents[1] / "data"


def _poses_along(log: Path) -> np.ndarray:
    """``t x y yaw`` rows walking the ground-truth positions of a slam_comparison_tools log
    in 0.1 m steps, turning on the spot at most 3 degrees a step (simul-gridmap's odometry
    is zero, so ICP must follow the robot from the scans alone)."""
    pts = np.loadtxt(log, delimiter=",", skiprows=1, usecols=(3, 4))
    out: list[tuple[float, float, float]] = []
    yaw: float | None = None
    for a, b in zip(pts[:-1], pts[1:]):
        d = float(np.hypot(*(b - a)))
        if d < 0.05:
            continue
        target = float(np.arctan2(b[1] - a[1], b[0] - a[0]))
        yaw = target if yaw is None else yaw
        turn = float(np.arctan2(np.sin(target - yaw), np.cos(target - yaw)))
        steps = int(np.ceil(abs(turn) / np.radians(3)))
        out += [(a[0], a[1], yaw + turn * j / steps) for j in range(1, steps + 1)]
        yaw = target
        n = max(1, int(d / 0.1))
        out += [(*(a + (b - a) * j / n), yaw) for j in range(n)]
    xyz = np.array(out)
    return np.column_stack([np.arange(len(xyz)), xyz])  # time = step index


@pytest.fixture(scope="module")
def simulated_office(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The office world of slam_comparison_tools as an MRPT sequence: its ground-truth map
    converted with image2gridmap, laser scans simulated along its ground-truth path with
    simul-gridmap; the ground truth written as TUM (time = step index, as icp-slam logs)."""
    if not all(shutil.which(p) for p in ("simul-gridmap", "image2gridmap")):
        pytest.skip("simul-gridmap / image2gridmap absent (apt-get install mrpt-apps)")
    d = tmp_path_factory.mktemp("office_sim")
    gt_yaml = DATA / "slam_comparison_tools" / "ground_truths" / "office_ground_truth.yaml"
    gt = load_map(gt_yaml)
    cv2.imwrite(str(d / "gt.png"), gt.meta["pixels"])
    res, (ox, oy, _) = gt.resolution, gt.origin
    # image2gridmap places the world origin at pixel (px, py), py counted from the top row
    subprocess.run(["image2gridmap", "-w", "-i", str(d / "gt.png"), "-r", str(res),
                    "--px", str(-ox / res), "--py", str(gt.shape[0] - 1 + oy / res),
                    "-o", str(d / "gt.gridmap.gz")],
                   check=True, capture_output=True, stdin=subprocess.DEVNULL, timeout=60)
    poses = _poses_along(DATA / "trajectories" / "slam_comparison_tools" / "office"
                         / "gmapping_pose_log.csv")
    np.savetxt(d / "poses.txt", poses, fmt="%.6f")
    subprocess.run(["simul-gridmap", "-n", "-g", str(d / "gt.gridmap.gz"), "-p",
                    str(d / "poses.txt"), "-o", str(d / "office.rawlog")],
                   check=True, capture_output=True, stdin=subprocess.DEVNULL, timeout=120)
    quat = np.column_stack([np.zeros((len(poses), 2)), np.sin(poses[:, 3] / 2),
                            np.cos(poses[:, 3] / 2)])
    np.savetxt(d / "gt.tum", np.column_stack([poses[:, :3], np.zeros(len(poses)), quat]),
               fmt="%.6f")
    return {"rawlog": d / "office.rawlog", "trajectory": d / "gt.tum", "map": gt_yaml,
            "poses": d / "poses.txt"}


def test_a_simulated_sequence_with_ground_truth_is_run_and_scored(
        tmp_path: Path, simulated_office: dict[str, Path]) -> None:
    n_poses = len(np.loadtxt(simulated_office["poses"]))
    assert n_poses > 1000
    cfg = yaml.safe_load(EXAMPLE.read_text())
    icp = cfg["algorithms"]["icp-slam"]
    # no odometry in the simulated rawlog: localise with ICP at every step
    icp["config_overrides"].update({
        "MappingApplication.localizationLinDistance": 0,
        "MappingApplication.localizationAngDistance": 0,
        "MappingApplication.insertionLinDistance": 0.5,
        "MappingApplication.insertionAngDistance": 15,
    })
    cfg["algorithms"] = {"icp-slam": icp}
    cfg.update(iterations=2, output=str(tmp_path / "runs"), base_dir=str(tmp_path),
               timeout=120)
    cfg["sequences"] = {"office_sim": {
        "input": str(simulated_office["rawlog"]),
        "groundtruth": str(simulated_office["trajectory"]),
        "groundtruth_map": str(simulated_office["map"]),
    }}
    result = runner.run(cfg)
    rows = result["rows"]
    assert [r["outcome"] for r in rows] == ["ok", "ok"], [r.get("reason") for r in rows]
    recs = read_results(tmp_path / "runs" / "results.jsonl")
    assert len(recs) == 2 and recs["error"].isna().all()
    # the estimated path (one pose per simulated scan) is associated with the ground truth
    assert (recs["ate_n"] >= n_poses - 2).all(), recs["ate_n"].tolist()
    assert (recs["ate_rmse"] > 0).all() and np.isfinite(recs["ate_rmse"]).all()
    # icp-slam is deterministic: both iterations give one answer
    assert recs["ate_rmse"].nunique() == 1 and recs["corners"].nunique() == 1
    summary = result["summary"].set_index("algorithm")
    assert summary.loc["icp-slam", "ate_rmse_mean"] == pytest.approx(recs["ate_rmse"].iloc[0])
    # and the map against the ground-truth map the scans were simulated in
    assert recs["gt_error"].isna().all(), recs["gt_error"].tolist()
    for col in ("gt_f1", "gt_iou", "gt_ne", "gt_reverse", "gt_coverage"):
        assert recs[col].notna().all(), col
    assert (recs["gt_f1"] > 0).all() and (recs["gt_f1"] <= 1).all()
    assert recs["gt_f1"].nunique() == 1
