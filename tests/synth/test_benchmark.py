"""Generated sequences in `slamq run` configs (slamq.synth.benchmark): the recipe expands
into named sequences, their files are generated once, and every run of them is scored
against the exact path and map (the benchmark's study: studies/tests)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

from slamq.errors import ParamError
from slamq.runner.config import load_config
from slamq.runner.runner import run

# A program that "maps" perfectly: it copies the exact map (in the frame of the first pose,
# where MRPT maps start) and the exact path out of the generated sequence's folder.
PERFECT = [sys.executable, "-c",
           "import shutil, sys, pathlib; seq = pathlib.Path(sys.argv[1]).parent; "
           "out = pathlib.Path(sys.argv[2]); out.mkdir(parents=True, exist_ok=True); "
           "shutil.copy(seq / 'visible_map.pgm', out / 'visible_map.pgm'); "
           "shutil.copy(seq / 'visible_map_start.yaml', out / 'map.yaml'); "
           "shutil.copy(seq / 'gt.tum', out / 'path.tum')",
           "{input}", "{out}"]

TINY = {"worlds": [{"kind": "office", "seed": 1, "size": [8, 6]}], "noise": ["none", "high"],
        "seeds": [0], "laser": {"beams": 181}, "drive": {"length": 8.0}}


def _config(tmp_path: Path, synth: dict) -> dict:
    return {"base_dir": str(tmp_path), "output": "out", "report": False,
            "sequences": {"gen": {"synth": synth}},
            "algorithms": {"perfect": {"command": PERFECT, "outputs": {
                "map": {"path": "map.yaml", "format": "yaml"},
                "trajectory": {"path": "path.tum", "format": "tum"}}}}}


def test_a_recipe_expands_into_named_sequences_with_their_ground_truth(tmp_path: Path) -> None:
    cfg = load_config({**_config(tmp_path, {"worlds": 3, "kinds": ["hall", "loop"],
                                             "noise": ["low", "high"], "seeds": [0, 1]})})
    names = [s.name for s in cfg.sequences]
    assert len(names) == 3 * 2 * 2 and len(set(names)) == len(names)
    assert names[:3] == ["gen-w00-hall-low-s0", "gen-w00-hall-low-s1", "gen-w00-hall-high-s0"]
    assert "gen-w01-loop-low-s0" in names and "gen-w02-hall-high-s1" in names
    s = cfg.sequences[0]
    assert s.input == tmp_path / "out/sequences/gen-w00-hall-low-s0/gen-w00-hall-low-s0.rawlog"
    assert s.groundtruth.name == "gt.tum"
    assert s.groundtruth_map.name == "visible_map_start.yaml"


@pytest.mark.parametrize("synth, words", [
    ({"worlds": 1, "colour": "red"}, "unknown keys colour"),
    ({"worlds": 1, "kinds": ["castle"]}, "unknown world kind 'castle'"),
    ({"worlds": 1, "noise": ["extreme"]}, "unknown preset 'extreme'"),
    ({"worlds": 0}, "worlds must be >= 1"),
    ({"worlds": [{"kind": "office", "floor": 2}]}, "worlds[0] must be"),
    ({"worlds": 1, "input": "video"}, "input must be one of"),
    ({"worlds": 1, "groundtruth_map": "blurry"}, "groundtruth_map must be visible or gt"),
    ({"worlds": 1, "laser": {"colour": 1}}, "laser: unknown keys colour"),
    ({"worlds": 1, "drive": {"wings": 2}}, "drive: unknown keys wings"),
    ({"worlds": 1, "drive": 3}, "drive must be a mapping"),
])
def test_a_bad_recipe_is_refused_naming_the_key(tmp_path: Path, synth: dict,
                                                words: str) -> None:
    with pytest.raises(ParamError, match=r"sequences\.gen\.synth") as e:
        load_config(_config(tmp_path, synth))
    assert words in str(e.value)


def test_a_dry_run_generates_nothing(tmp_path: Path) -> None:
    rows = run(_config(tmp_path, TINY), dry_run=True)["rows"]
    assert [r["outcome"] for r in rows] == ["planned", "planned"]
    assert not (tmp_path / "out" / "sequences").exists()


def test_generated_sequences_are_made_once_and_scored_against_the_exact_truth(
        tmp_path: Path) -> None:
    result = run(_config(tmp_path, TINY))
    rows = {r["sequence"]: r for r in result["rows"]}
    assert set(rows) == {"gen-w01-office-none-s0", "gen-w01-office-high-s0"}
    assert all(r["outcome"] == "ok" for r in rows.values())
    from slamq.results.formats import read_results

    recs = read_results(result["results"]).set_index("sequence")
    # the exact path against itself, the exact map against itself (in the start frame)
    assert (recs["ate_rmse"] < 1e-6).all(), recs["ate_rmse"].to_dict()
    assert (recs["gt_f1"] > 0.999).all(), recs["gt_f1"].to_dict()
    folder = tmp_path / "out/sequences/gen-w01-office-high-s0"
    recipe = json.loads((folder / "recipe.json").read_text())
    assert recipe["noise"] == "high" and recipe["world"]["size"] == [8.0, 6.0]
    made = (folder / "recipe.json").stat().st_mtime_ns
    again = run(_config(tmp_path, TINY))
    assert all(r.get("skipped") for r in again["rows"])  # same files, same keys
    assert (folder / "recipe.json").stat().st_mtime_ns == made  # not generated again


EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.mark.skipif(not all(__import__("shutil").which(p) for p in
                            ("rbpf-slam", "icp-slam", "graphslam-engine")),
                    reason="MRPT's SLAM programs are not installed (apt-get install mrpt-apps)")
def test_the_quick_benchmark_runs_three_real_slam_programs(tmp_path: Path) -> None:
    import yaml

    doc = yaml.safe_load((EXAMPLES / "benchmark-quick.yaml").read_text())
    doc.update(base_dir=str(tmp_path), report=False)
    result = run(doc)
    rows = result["rows"]
    assert sorted(r["algorithm"] for r in rows) == ["graphslam-engine", "icp-slam", "rbpf-slam"]
    assert all(r["outcome"] == "ok" for r in rows), [(r["algorithm"], r["reason"]) for r in rows]
    from slamq.results.formats import read_results

    recs = read_results(result["results"]).set_index("algorithm")
    # every ok run has ATE and a ground-truth map score, and these maps are good ones
    assert (recs["ate_rmse"] < 0.3).all(), recs["ate_rmse"].to_dict()
    assert (recs["gt_f1"] > 0.8).all(), recs["gt_f1"].to_dict()
