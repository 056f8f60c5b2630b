"""Wall time, CPU time and peak RSS of every run as result columns (scores.csv, summary.csv)
and the report's "Resources and parameters" page (quality against cost and against each
swept parameter, mean +- std over iterations)."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pandas as pd
import pytest

from slamq.runner import runner

PY = sys.executable

#: Busy-waits n/100 s of CPU, holds n MB, writes a map and a trajectory whose error grows
#: with the iteration and shrinks with n.
SLAM = """\
import pathlib, sys, time
out, n, it = pathlib.Path(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
hold = bytearray(n * 1024 * 1024)
for i in range(0, len(hold), 4096):
    hold[i] = 1
end = time.process_time() + n / 100
while time.process_time() < end:
    pass
w = h = 30
img = bytearray([254]) * (w * h)
for y in range(4, 8):
    img[y * w + 3:y * w + 27] = bytes([0]) * 24
(out / "map.pgm").write_bytes(b"P5\\n%d %d\\n255\\n" % (w, h) + bytes(img))
err = 0.5 / n * it
(out / "traj.txt").write_text("".join(f"{i} {i} {err * (i % 2)} 0 0 0 0 1\\n" for i in range(8)))
"""


def test_resources_are_result_columns_and_plotted_against_the_sweep(tmp_path: Path) -> None:
    (tmp_path / "slam.py").write_text(SLAM)
    (tmp_path / "in.txt").write_text("x\n")
    (tmp_path / "gt.txt").write_text("".join(f"{i} {i} 0 0 0 0 0 1\n" for i in range(8)))
    cfg = {"base_dir": str(tmp_path), "output": "out", "iterations": 2, "parallel": 2,
           "sequences": {"seq": {"input": "in.txt", "groundtruth": "gt.txt"}},
           "evaluate": {"ate_align": "none"},
           "algorithms": {"pf": {
               "command": [PY, str(tmp_path / "slam.py"), "{out}", "{param.particles}",
                           "{iteration}"],
               "params": {"particles": [5, 50]},
               "outputs": {"map": {"path": "map.pgm", "format": "image"},
                           "trajectory": {"path": "traj.txt", "format": "tum"}}}}}
    result = runner.run(cfg)
    assert [r["outcome"] for r in result["rows"]] == ["ok"] * 4
    out = tmp_path / "out"
    scores = pd.read_csv(out / "scores.csv")
    assert len(scores) == 4
    assert {"wall_s", "cpu_s", "peak_rss_mb", "param.particles", "ate_rmse"} <= set(scores)
    one = scores.set_index(["param.particles", "run"])
    stored = json.loads((out / "pf" / "particles=50" / "seq" / "1" / "run.json").read_text())
    assert one.loc[(50, 1), "wall_s"] == pytest.approx(stored["wall"])
    assert one.loc[(50, 1), "cpu_s"] == pytest.approx(stored["user_cpu"] + stored["sys_cpu"])
    assert one.loc[(50, 1), "peak_rss_mb"] == pytest.approx(stored["max_rss_kb"] / 1024)
    # the sweep shows in the numbers: more "particles", more CPU and memory, less error
    mean = scores.groupby("param.particles")[["cpu_s", "peak_rss_mb", "ate_rmse"]].mean()
    assert mean["cpu_s"].is_monotonic_increasing and mean["peak_rss_mb"].is_monotonic_increasing
    assert mean["ate_rmse"].is_monotonic_decreasing
    summary = pd.read_csv(out / "summary.csv")
    for c in ("wall_s", "cpu_s", "peak_rss_mb"):
        assert summary[f"{c}_mean"].notna().all() and summary[f"{c}_std"].notna().all()
    report = out / "report"
    page = (report / "resources.html").read_text()
    assert "Quality against cost" in page and "pf: particles" in page
    assert (report / "img" / "resources_quality_cost.png").stat().st_size > 5000
    assert (report / "img" / "resources_sweep_pf_particles.png").stat().st_size > 5000
    assert 'href="resources.html"' in (report / "index.html").read_text()
    runner.score(runner.load_config(cfg), result["rows"])  # scoring again: one link, same rows
    assert (report / "index.html").read_text().count('href="resources.html"') == 1
    assert len(pd.read_csv(out / "scores.csv")) == 4
