"""Batches with relations ground truth: the ``rel_*`` columns (docs/spec.md 6a) from a
``<sequence>.relations`` file beside the runs, the manifest's ``relations`` column, or
``slamq batch --relations [SEQUENCE=]FILE``; in both results formats, the summary and the
command line; interpolation and unsorted trajectories as asked."""

from __future__ import annotations

import json
import math
from pathlib import Path

import cv2
import numpy as np
import pandas as pd
import pytest

import slamq
from slamq.batch.runs import discover_runs
from slamq.cli import main
from slamq.results.formats import read_records

T0 = 500.0


def _pose(i: int) -> tuple[float, float, float]:
    """The robot at step i: 0.3 m a step along a circle of radius 3 m."""
    a = 0.1 * i
    return 3 * math.sin(a), 3 - 3 * math.cos(a), a


def _tum(path: Path, steps: list[int], dt: float = 0.0, drift: float = 0.0) -> Path:
    """Poses of ``steps`` at ``T0 + step + dt``, x stretched by ``1 + drift``."""
    lines = []
    for i in steps:
        x, y, yaw = _pose(i)
        lines.append(f"{T0 + i + dt:.6f} {x * (1 + drift):.9f} {y:.9f} 0 0 0 "
                     f"{math.sin(yaw / 2):.12f} {math.cos(yaw / 2):.12f}")
    path.write_text("\n".join(lines) + "\n")
    return path


def _relations(path: Path, pairs: list[tuple[int, int]]) -> Path:
    rows = []
    for i, j in pairs:
        x1, y1, a1 = _pose(i)
        x2, y2, a2 = _pose(j)
        c, s = math.cos(a1), math.sin(a1)
        dx, dy = x2 - x1, y2 - y1
        rows.append(f"{T0 + i:.6f} {T0 + j:.6f} {c * dx + s * dy:.12f} "
                    f"{-s * dx + c * dy:.12f} 0 0 0 {a2 - a1:.12f}")
    path.write_text("\n".join(rows) + "\n")
    return path


PAIRS = [(1, 5), (5, 9), (9, 20), (2, 30)]


def _map(path: Path) -> Path:
    img = np.full((40, 40), 254, np.uint8)
    img[10, 5:35] = 0
    img[10:30, 5] = 0
    cv2.imwrite(str(path), img)
    return path


def _flat(root: Path, seq: str = "lab", drift: float = 0.0) -> Path:
    folder = root / seq
    folder.mkdir(parents=True)
    _map(folder / "exact_map.pgm")
    _tum(folder / "exact.tum", list(range(40)))
    _map(folder / "drift_map.pgm")
    _tum(folder / "drift.tum", list(range(40)), drift=0.05 + drift)
    return folder


def test_a_relations_file_beside_the_sequence_gives_rel_columns(tmp_path: Path) -> None:
    folder = _flat(tmp_path)
    rel = _relations(folder / "lab.relations", PAIRS)
    out = tmp_path / "r.parquet"
    recs = {r["algorithm"]: r for r in slamq.evaluate_many(tmp_path, threads=2, out=out)}
    assert set(recs) == {"exact", "drift"}
    exact, drift = recs["exact"], recs["drift"]
    for r in (exact, drift):
        assert r["relations"] == str(rel) and r["rel_error"] is None
        assert (r["rel_n"], r["rel_n_relations"], r["rel_n_unplaced"]) == (4, 4, 0)
    assert exact["rel_trans_abs_mean"] == pytest.approx(0.0, abs=1e-9)
    direct = slamq.relations(slamq.load_trajectory(folder / "drift.tum"),
                             slamq.load_relations(rel))
    for k, v in direct.stats().items():
        assert drift[f"rel_{k}"] == pytest.approx(v, rel=1e-12), k
    assert drift["rel_trans_abs_mean"] > 0.01
    # every results format keeps the columns and their types
    list(slamq.evaluate_many(tmp_path, threads=1, out=tmp_path / "r.jsonl"))
    for name in ("r.parquet", "r.jsonl"):
        stored = {r["algorithm"]: r for r in read_records(tmp_path / name)}
        assert stored["drift"]["rel_trans_max"] == pytest.approx(direct.trans_max)
        assert isinstance(stored["drift"]["rel_n"], int), name
    summary = slamq.summarize(out)
    assert summary.set_index("algorithm").loc["drift", "rel_trans_abs_mean_mean"] == \
        pytest.approx(direct.trans_abs_mean)
    # the relations error is ground truth: the verdict ranks by it, confidence high
    from slamq.verdict.ranking import summarize as ranking_summary
    from slamq.verdict.rule import sequence_verdict, verdict_sentence

    v = sequence_verdict(ranking_summary(pd.DataFrame(list(recs.values()))), "lab")
    assert (v["best"], v["ranking"], v["basis"]) == (
        "exact", ["exact", "drift"], ["rel_trans_abs_mean", "rel_rot_abs_mean"])
    assert v["confidence"].startswith("high: ranked by the relations error")
    assert "exact is best by relations error" in verdict_sentence(v)
    # resumed: nothing to do; the relations file gone: scored again, without rel_*
    assert list(slamq.evaluate_many(tmp_path, threads=1, out=out)) == []
    rel.unlink()
    again = list(slamq.evaluate_many(tmp_path, threads=1, out=out))
    assert len(again) == 2 and all(r["rel_n"] is None and r["relations"] is None
                                   for r in again)
    assert "rel_trans_abs_mean_mean" not in slamq.summarize(out).columns


def test_manifest_and_run_folders_find_the_relations(tmp_path: Path) -> None:
    run = tmp_path / "runs" / "exact" / "lab" / "1"
    run.mkdir(parents=True)
    _map(run / "map.pgm")
    _tum(run / "trajectory.tum", list(range(40)))
    _relations(tmp_path / "runs" / "lab.relations", PAIRS)  # at the root, named by sequence
    (found,) = discover_runs(tmp_path / "runs")
    assert found.relations == tmp_path / "runs" / "lab.relations"
    other = tmp_path / "m"
    other.mkdir()
    _map(other / "a.pgm")
    _tum(other / "a.tum", list(range(40)))
    _relations(other / "truth.rel.relations", PAIRS[:2])
    (other / "runs.csv").write_text("map,trajectory,relations\na.pgm,a.tum,"
                                    "truth.rel.relations\n")
    (rec,) = slamq.evaluate_many(other / "runs.csv", threads=1)
    assert rec["rel_n"] == 2 and rec["rel_trans_max"] == pytest.approx(0.0, abs=1e-9)


def test_slamq_batch_relations_option(tmp_path: Path, capsys) -> None:
    _flat(tmp_path / "data", "a")
    _flat(tmp_path / "data", "b")
    rel = _relations(tmp_path / "truth.relations", PAIRS)
    out = tmp_path / "r.jsonl"
    assert main(["batch", str(tmp_path / "data"), "--out", str(out), "--no-progress",
                 "--relations", f"a={rel}"]) == 0
    recs = read_records(out)
    assert {(r["sequence"], r["algorithm"], r["rel_n"]) for r in recs} == {
        ("a", "exact", 4), ("a", "drift", 4), ("b", "exact", None), ("b", "drift", None)}
    printed = capsys.readouterr().out
    assert "relations trans. error (m)" in printed
    out2 = tmp_path / "r2.jsonl"
    assert main(["batch", str(tmp_path / "data"), "--out", str(out2), "--no-progress",
                 "--relations", str(rel)]) == 0
    assert all(r["rel_n"] == 4 for r in read_records(out2))
    assert main(["batch", str(tmp_path / "data"), "--out", str(out2), "--no-progress",
                 "--relations", str(tmp_path / "none.relations")]) == 2
    assert "none.relations: --relations: no such file" in capsys.readouterr().err


def test_interpolation_and_unsorted_trajectories_as_asked(tmp_path: Path) -> None:
    folder = tmp_path / "lab"
    folder.mkdir()
    _map(folder / "late_map.pgm")
    _tum(folder / "late.tum", list(range(40)), dt=0.3)  # stamps between the relations'
    _map(folder / "shuffled_map.pgm")
    steps = list(range(40))
    steps[10], steps[11] = steps[11], steps[10]
    _tum(folder / "shuffled.tum", steps)
    _relations(folder / "lab.relations", PAIRS)
    recs = {r["algorithm"]: r for r in slamq.evaluate_many(tmp_path, threads=1)}
    assert "none of the 4 relations" in recs["late"]["rel_error"]
    assert "non-monotonic timestamps" in recs["shuffled"]["rel_error"]
    recs = {r["algorithm"]: r for r in slamq.evaluate_many(
        tmp_path, threads=1, rel_interpolate=True, rel_max_gap=2.0, ate_unsorted="sort")}
    assert recs["late"]["rel_n"] == 4 and recs["late"]["rel_n_interpolated"] == 4
    assert recs["late"]["rel_trans_abs_mean"] < 0.01  # a circle's chord against its arc
    assert recs["shuffled"]["rel_n"] == 4
    assert recs["shuffled"]["rel_trans_abs_mean"] == pytest.approx(0.0, abs=1e-9)
    assert json.loads(recs["late"]["config"])["rel"] == [True, 2.0, None]
    with pytest.raises(slamq.ParamError, match="rel_max_gap must be a number >= 0"):
        list(slamq.evaluate_many(tmp_path, rel_max_gap=-1))
