"""End to end with MRPT's real SLAM programs (skipped without mrpt-apps): rbpf-slam with
two particle counts and icp-slam, 3 iterations each, in parallel, on the last 50 steps of
MRPT's real laser dataset (cut with rawlog-edit so the test stays short)."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest
import yaml

from slamq.run import runner
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
