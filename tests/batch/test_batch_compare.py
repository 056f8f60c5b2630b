"""Batches with ground-truth maps: the ``gt_*`` columns (docs/spec.md section 7) from a
sequence's reference map, a ``gt_map.yaml`` / ``ground_truth*.yaml`` in the sequence
folder, or the manifest's ``gt_map`` column; the reference itself is never compared."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest
from conftest import TEST_DATA

import slamq
from slamq.batch.runs import discover_runs
from slamq.results.columns import GT_COLUMNS
from slamq.results.formats import read_records

ROOT = TEST_DATA / "slam_comparison_tools"


def test_flat_layout_reference_map_gives_gt_columns(tmp_path: Path) -> None:
    out = tmp_path / "r.parquet"
    recs = list(slamq.evaluate_many(ROOT, threads=2, out=out))
    by = {r["algorithm"]: r for r in recs}
    ref = by.pop("ground_truth")
    assert all(ref[c] is None for c in GT_COLUMNS)
    for algo, r in by.items():
        assert r["gt_map"].endswith("office_ground_truth.yaml") and r["gt_error"] is None
        assert 0 <= r["gt_f1"] <= 1 and r["gt_chamfer"] >= 0, algo
    assert by["slam_toolbox"]["gt_f1"] > 0.98 > by["cartographer"]["gt_f1"]
    direct = slamq.compare(by["gmapping"]["map"], by["gmapping"]["gt_map"], threads=1)
    assert by["gmapping"]["gt_chamfer"] == direct.chamfer
    stored = {r["algorithm"]: r for r in read_records(out)}
    assert stored["gmapping"]["gt_f1"] == by["gmapping"]["gt_f1"]
    assert isinstance(stored["gmapping"]["gt_truncated"], int)
    # resume: nothing left to do
    assert list(slamq.evaluate_many(ROOT, threads=2, out=out)) == []


def _map(folder: Path, name: str, img: np.ndarray) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(folder / f"{name}.pgm"), img)
    (folder / f"{name}.yaml").write_text(
        f"image: {name}.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n")
    return folder / f"{name}.yaml"


def _walls(missing: bool = False) -> np.ndarray:
    img = np.full((60, 80), 254, np.uint8)
    img[10, 5:75] = 0
    img[50, 5:75] = 0
    img[10:51, 5] = 0
    if not missing:
        img[10:51, 74] = 0
    return img


def test_gt_map_yaml_in_the_sequence_folder_of_a_runs_layout(tmp_path: Path) -> None:
    _map(tmp_path / "good" / "lab" / "1", "map", _walls())
    _map(tmp_path / "bad" / "lab" / "1", "map", _walls(missing=True))
    _map(tmp_path / "good" / "lab", "gt_map", _walls())
    runs = discover_runs(tmp_path)
    refs = [r for r in runs if r.algorithm == "ground_truth"]
    assert len(refs) == 1 and refs[0].sequence == "lab" and refs[0].gt_map is None
    assert all(r.gt_map == refs[0].map for r in runs if r.algorithm != "ground_truth")
    recs = {r["algorithm"]: r for r in slamq.evaluate_many(tmp_path, threads=1)}
    assert recs["good"]["gt_f1"] == 1.0 and recs["good"]["gt_ne"] == 0.0
    assert recs["bad"]["gt_recall"] < 1.0 and recs["bad"]["gt_ne"] > 0.0
    assert recs["ground_truth"]["gt_f1"] is None


def test_ground_truth_yaml_in_a_flat_folder(tmp_path: Path) -> None:
    _map(tmp_path / "lab", "hector_map", _walls(missing=True))
    _map(tmp_path / "lab", "ground_truth_v2", _walls())
    recs = {r["algorithm"]: r for r in slamq.evaluate_many(tmp_path, threads=1)}
    assert set(recs) == {"hector", "ground_truth"}
    assert recs["hector"]["gt_map"].endswith("ground_truth_v2.yaml")
    assert recs["hector"]["gt_precision"] == 1.0


def test_manifest_gt_map_column_and_a_bad_ground_truth(tmp_path: Path) -> None:
    a = _map(tmp_path / "maps", "a", _walls())
    gt = _map(tmp_path / "gts", "truth", _walls(missing=True))
    (tmp_path / "runs.csv").write_text(
        "algorithm, sequence, map, gt_map\n"
        f"a, s1, {a.relative_to(tmp_path)}, {gt.relative_to(tmp_path)}\n"
        f"a, s2, {a.relative_to(tmp_path)}, gts/missing.yaml\n"
        f"a, s3, {a.relative_to(tmp_path)},\n")
    recs = {r["sequence"]: r for r in slamq.evaluate_many(tmp_path / "runs.csv", threads=1)}
    assert recs["s1"]["gt_precision"] < 1.0 and recs["s1"]["gt_recall"] == 1.0
    assert recs["s2"]["error"] is None and "missing.yaml" in recs["s2"]["gt_error"]
    assert recs["s3"]["gt_map"] is None and recs["s3"]["gt_f1"] is None


def test_adding_a_ground_truth_reevaluates_on_resume(tmp_path: Path) -> None:
    data = tmp_path / "data"
    _map(data / "lab", "hector_map", _walls())
    out = tmp_path / "r.jsonl"
    (first,) = slamq.evaluate_many(data, out=out, threads=1)
    assert first["gt_map"] is None
    _map(data / "lab", "gt_map", _walls())
    again = {r["algorithm"]: r for r in slamq.evaluate_many(data, out=out, threads=1)}
    assert again["hector"]["gt_f1"] == 1.0
    assert "gt" not in again or again.get("gt", {}).get("gt_f1") is None


def test_gt_options_and_their_checks(tmp_path: Path) -> None:
    shutil.copytree(ROOT, tmp_path / "d")
    recs = [r for r in slamq.evaluate_many(tmp_path / "d", threads=1, gt_align="origin",
                                           gt_tolerance=0.2, gt_max_distance=0.5)
            if r["algorithm"] == "cartographer"]
    assert recs[0]["gt_icp_rms"] is None or math.isnan(recs[0]["gt_icp_rms"])
    with pytest.raises(slamq.ParamError, match="gt_align"):
        list(slamq.evaluate_many(tmp_path / "d", gt_align="best"))
    with pytest.raises(slamq.ParamError, match="gt_tolerance"):
        list(slamq.evaluate_many(tmp_path / "d", gt_tolerance=-1))
