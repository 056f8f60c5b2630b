"""A rerun of ``slamq run`` with nothing to run skips the scoring, GIFs and report whose
inputs did not change, and redoes exactly what depends on a changed input (real files, a
real "SLAM" program writing MRPT-style grids; what was done is read from
``OUTPUT/stages.jsonl``, the results file and file modification times)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from slamq.results import read_results
from slamq.runner import runner

pytest.importorskip("matplotlib", reason="the report needs the 'report' extra")
pytest.importorskip("PIL", reason="the GIFs need the 'report' extra")

SLAM = """\
import sys, pathlib, numpy as np, cv2
out = pathlib.Path(sys.argv[1]); seed = int(sys.argv[2])
def grid(k):
    img = np.full((40, 40), 255, np.uint8); img[4:36, 4:36] = 200
    img[6:6 + k, 8:30] = 0; img[10:30, 8 + seed] = 0
    return img
(out / "maps").mkdir()
for i in (1, 2):
    cv2.imwrite(str(out / "maps" / f"snap_{i:03d}.png"), grid(i))
    (out / "maps" / f"snap_{i:03d}_limits.txt").write_text("0 2 0 2\\n")
cv2.imwrite(str(out / "final.png"), grid(3))
(out / "final_limits.txt").write_text("0 2 0 2\\n")
"""


def _config(tmp_path: Path, **evaluate) -> dict:
    (tmp_path / "in.txt").write_text("input\n")
    (tmp_path / "slam.py").write_text(SLAM)
    return {"base_dir": str(tmp_path), "output": "out", "sequences": {"seq": "in.txt"},
            "iterations": 2, "parallel": 1, "report": True, "evaluate": evaluate,
            "algorithms": {"fake": {
                "command": [sys.executable, str(tmp_path / "slam.py"), "{out}", "{seed}"],
                "outputs": {"map": {"path": "final.png", "format": "mrpt"},
                            "snapshots": {"path": "maps/snap_*.png", "format": "mrpt"}}}}}


def _stages(out: Path) -> dict[str, dict]:
    """The stage lines of the last invocation."""
    lines = [json.loads(x) for x in (out / "stages.jsonl").read_text().splitlines()]
    return {s["stage"]: s for s in lines[-3:]}


def _mtimes(out: Path) -> dict[str, int]:
    files = [out / "report" / "index.html", *sorted(out.glob("fake/*/seq/*/building.gif")),
             *sorted((out / "report" / "maps").glob("*.html"))]
    return {str(f.relative_to(out)): f.stat().st_mtime_ns for f in files}


def test_a_rerun_redoes_only_what_depends_on_a_changed_file(tmp_path: Path) -> None:
    # --- an unchanged rerun: nothing scored, drawn or written
    cfg = _config(tmp_path)
    out = tmp_path / "out"
    first = runner.run(cfg)
    assert [r["outcome"] for r in first["rows"]] == ["ok", "ok"]
    s = _stages(out)
    assert (s["score"]["done"], s["gifs"]["done"], s["report"]["done"]) == (2, 2, 1)
    before = _mtimes(out)
    results = (out / "results.jsonl").read_bytes()
    # the files are touched (mtime only): content decides, so nothing is redone
    for f in out.glob("fake/*/seq/*/out/**/*.png"):
        os.utime(f)
    again = runner.run(cfg)
    s = _stages(out)
    assert (s["score"]["done"], s["score"]["skipped"]) == (0, 2)
    assert (s["gifs"]["done"], s["gifs"]["skipped"]) == (0, 2)
    assert (s["report"]["done"], s["report"]["skipped"]) == (0, 1)
    assert "skipped" in s["report"]["message"]
    assert _mtimes(out) == before
    assert (out / "results.jsonl").read_bytes() == results
    assert again["records"] == 0 and again["report"] == out / "report" / "index.html"

    # --- a changed map is scored again and the report rebuilt
    old = {r["run"]: r for r in read_results(out / "results.jsonl").to_dict("records")}
    # one run's final map gets an extra wall: only that run is scored again
    import cv2

    png = out / "fake" / "default" / "seq" / "2" / "out" / "final.png"
    img = cv2.imread(str(png), cv2.IMREAD_GRAYSCALE)
    img[30:33, 10:30] = 0
    cv2.imwrite(str(png), img)
    runner.run(cfg)
    s = _stages(out)
    assert (s["score"]["done"], s["score"]["skipped"]) == (1, 1)
    assert s["score"]["why"] == {"fake seq #2": ["map changed"]}
    assert s["report"]["done"] == 1 and "results changed" in s["report"]["message"]
    # only the changed map's detail page is drawn again
    assert (s["report"]["pages_drawn"], s["report"]["pages_kept"]) == (1, 1)
    assert (s["gifs"]["done"], s["gifs"]["skipped"]) == (0, 2)  # snapshots unchanged
    new = {r["run"]: r for r in read_results(out / "results.jsonl").to_dict("records")}
    assert len(new) == 2
    assert new["1"]["hash"] == old["1"]["hash"] and new["1"]["seconds"] == old["1"]["seconds"]
    assert new["2"]["hash"] != old["2"]["hash"] and new["2"]["occupied"] > old["2"]["occupied"]
    after = _mtimes(out)
    assert after["report/index.html"] > before["report/index.html"]
    pages = sorted(k for k in after if k.startswith("report/maps/"))
    assert len(pages) == 2 and pages == sorted(k for k in before if k.startswith("report/maps/"))
    assert after[pages[0]] == before[pages[0]]  # run 1's page: kept
    assert after[pages[1]] > before[pages[1]]  # run 2's page: drawn again
    assert {k: v for k, v in after.items() if k.endswith(".gif")} == \
        {k: v for k, v in before.items() if k.endswith(".gif")}
    # a changed snapshot redraws that run's GIF (and the report, which animates them)
    snap = png.parent / "maps" / "snap_001.png"
    img = cv2.imread(str(snap), cv2.IMREAD_GRAYSCALE)
    img[20, 20] = 0
    cv2.imwrite(str(snap), img)
    runner.run(cfg)
    s = _stages(out)
    assert (s["score"]["done"], s["gifs"]["done"], s["gifs"]["skipped"]) == (0, 1, 1)
    assert s["gifs"]["why"] == {"fake seq #2": ["snapshots changed"]}
    assert s["report"]["done"] == 1 and "snapshots changed" in s["report"]["message"]
    assert (s["report"]["pages_drawn"], s["report"]["pages_kept"]) == (1, 1)
    # the report deleted: written again, nothing scored
    (out / "report" / "index.html").unlink()
    runner.run(cfg)
    s = _stages(out)
    assert s["score"]["done"] == 0 and s["report"]["done"] == 1
    assert (out / "report" / "index.html").is_file()
    # slamq run says what it skipped and why
    import yaml
    from conftest import slamq_env

    cfg.pop("base_dir")  # a config file's folder is its base
    (tmp_path / "run.yaml").write_text(yaml.safe_dump(cfg))
    proc = subprocess.run([sys.executable, "-m", "slamq", "run", str(tmp_path / "run.yaml")],
                          capture_output=True, text=True, env=slamq_env(), timeout=120)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert "scores: 0 of 2 maps scored; 2 skipped (map, trajectory, ground truth, settings " \
        "and slamq version as when they were scored)" in lines
    assert "GIFs: 0 of 2 made; 2 skipped (snapshots as when they were drawn)" in lines
    assert "report: skipped (results, scores, maps, snapshots and slamq version as when it " \
        "was written)" in lines
    assert f"report unchanged: {out / 'report' / 'index.html'}" in lines


def test_other_settings_or_another_slamq_version_redo_everything(tmp_path: Path) -> None:
    out = tmp_path / "out"
    runner.run(_config(tmp_path))
    runner.run(_config(tmp_path, harris_k=0.05))  # other scoring parameters
    s = _stages(out)
    assert (s["score"]["done"], s["score"]["skipped"]) == (2, 0)
    assert set(map(tuple, s["score"]["why"].values())) == {("evaluate settings changed",)}
    assert s["report"]["done"] == 1
    assert {r["param_harris_k"] for r in read_results(out / "results.jsonl")
            .to_dict("records")} == {0.05}
    # the stamps say an older slamq made everything: scores, GIFs and report are redone
    cache = out / ".slamq-cache.json"
    data = json.loads(cache.read_text())
    for stage in ("score", "gif"):
        for stamp in data[stage].values():
            stamp["version"] = "0.0.1"
    data["report"]["report"]["inputs"]["version"] = "0.0.1"
    cache.write_text(json.dumps(data))
    runner.run(_config(tmp_path, harris_k=0.05))
    s = _stages(out)
    assert (s["score"]["done"], s["gifs"]["done"], s["report"]["done"]) == (2, 2, 1)
    assert set(map(tuple, s["score"]["why"].values())) == {("slamq version changed",)}
    assert "slamq version changed" in s["report"]["message"]
    assert s["report"]["pages_drawn"] == 2  # the records were scored again
    # a deleted results file: every run scored again
    (out / "results.jsonl").unlink()
    runner.run(_config(tmp_path, harris_k=0.05))
    s = _stages(out)
    assert s["score"]["done"] == 2
    assert set(map(tuple, s["score"]["why"].values())) == {
        ("no stored record (or it failed)",)}
    assert len(read_results(out / "results.jsonl")) == 2
    assert np.isfinite(read_results(out / "results.jsonl")["occupied_fraction"]).all()


def test_changed_outputs_are_collected_again_without_running(tmp_path: Path) -> None:
    """An algorithm whose ``outputs.trajectory`` now names another file the program wrote
    (rbpf-slam's mean path -> its most likely path) is collected again and rescored; the
    program is not run again (it counts its starts in a file)."""
    (tmp_path / "in.txt").write_text("input\n")
    (tmp_path / "slam.py").write_text(SLAM + """\
with open(out.parent.parent / "starts.txt", "a") as f:
    f.write("1\\n")
(out / "a.tum").write_text("0 0 0 0 0 0 0 1\\n1 1 0 0 0 0 0 1\\n2 2 0 0 0 0 0 1\\n")
(out / "b.tum").write_text("0 0 0 0 0 0 0 1\\n1 5 0 0 0 0 0 1\\n2 9 0 0 0 0 0 1\\n")
""")
    cfg = {"base_dir": str(tmp_path), "output": "out", "sequences": {"seq": "in.txt"},
           "iterations": 1, "parallel": 1,
           "algorithms": {"fake": {
               "command": [sys.executable, str(tmp_path / "slam.py"), "{out}", "{seed}"],
               "outputs": {"map": {"path": "final.png", "format": "mrpt"},
                           "trajectory": {"path": "a.tum", "format": "tum"}}}}}
    out = tmp_path / "out"
    runner.run(cfg)
    folder = next(out.glob("fake/*/seq/1"))
    starts = folder.parent / "starts.txt"
    assert starts.read_text() == "1\n"
    assert float((folder / "trajectory.tum").read_text().splitlines()[-1].split()[1]) == 2.0
    cfg["algorithms"]["fake"]["outputs"]["trajectory"]["path"] = "b.tum"
    runner.run(cfg)
    assert starts.read_text() == "1\n"  # not run again
    last = (folder / "trajectory.tum").read_text().splitlines()[-1].split()
    assert float(last[1]) == 9.0
    rec = json.loads((folder / "run.json").read_text())
    assert rec["outcome"] == "ok" and rec["trajectory"].endswith("trajectory.tum")
    assert "trajectory changed" in json.dumps(_stages(out)["score"])
