"""A cut of a real log (the first 300 scans of MIT CSAIL, 154 relations) through
``slamq run`` as examples/real2d.yaml runs it: a ``carmen:`` sequence converted with the
log's own timestamps, mapped by icp-slam and rbpf-slam, each run scored by the relations
error of Kümmerle et al. 2009 (``relations:``, the ``rel_*`` columns); skipped without the
data or MRPT."""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import pytest
import yaml

from slamq.runner import runner

DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "datasets2d"
EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "real2d.yaml"
LOG = DATA / "mit-csail" / "mit-csail.clf"
RELATIONS = DATA / "mit-csail" / "mit-csail.relations"

pytestmark = pytest.mark.skipif(
    not LOG.exists() or not all(shutil.which(p) for p in ("rbpf-slam", "icp-slam")),
    reason="../shared/data/datasets2d or MRPT (apt-get install mrpt-apps) absent",
)


def test_real_log_cut_scored_by_relations(tmp_path: Path) -> None:
    cfg = yaml.safe_load(EXAMPLE.read_text())
    example = cfg["sequences"]["mit-csail"]
    # the example's own sequence, its paths as the example gives them, cut to 300 scans
    assert (EXAMPLE.parent / example["carmen"]).resolve() == LOG.resolve()
    assert (EXAMPLE.parent / example["relations"]).resolve() == RELATIONS.resolve()
    cfg["algorithms"] = {k: cfg["algorithms"][k] for k in ("icp-slam", "rbpf-slam")}
    cfg["algorithms"]["icp-slam"]["params"] = {"grid": [1]}
    cfg["algorithms"]["rbpf-slam"]["params"] = {"particles": [5]}
    cfg.update(sequences={"csail300": {**example, "max_scans": 300}},
               output=str(tmp_path / "runs"), base_dir=str(EXAMPLE.parent), iterations=1,
               timeout=120)
    result = runner.run(cfg)
    rows = result["rows"]
    assert len(rows) == 2
    assert all(r["outcome"] == "ok" for r in rows), [(r["algorithm"], r["reason"]) for r in rows]
    folder = tmp_path / "runs" / "sequences" / "csail300"
    info = json.loads((folder / "conversion.json").read_text())
    # the rawlog keeps the log's clock: its first stamp is the log's first FLASER stamp
    assert info["scans"] == 300 and info["first"] == pytest.approx(1134864629.895182, abs=1e-6)
    recs = [json.loads(line) for line in (tmp_path / "runs" / "results.jsonl").open()]
    assert len(recs) == 2
    for rec in recs:
        assert rec["error"] is None and rec["rel_error"] is None, rec
        assert rec["rel_n_relations"] == 1172
        assert rec["rel_n"] + rec["rel_n_unplaced"] == 1172
        if rec["algorithm"].startswith("icp-slam"):
            # only the relations inside the cut are placed, each on a pose at its stamp
            assert rec["rel_n"] == 154 and rec["rel_n_interpolated"] == 0
        else:
            # rbpf-slam's most likely path has a pose per step its filter ran (every 1 m
            # or 40 deg): the relations inside the cut are placed between them
            assert 140 <= rec["rel_n"] <= 154 and rec["rel_n_interpolated"] > 100, rec
        assert all(math.isfinite(rec[f"rel_{s}"]) for s in
                   ("trans_abs_mean", "trans_abs_std", "rot_abs_mean", "trans_max"))
        # 300 scans of a log whose odometry alone is 0.053 m / 4.3 deg off here: a scan
        # matcher or filter that works stays within decimetres and a few degrees
        # (rbpf-slam's rotation placed between poses up to 40 deg apart: interpolation
        # adds a few degrees, docs/real-datasets.md)
        rot = 6.0 if rec["algorithm"].startswith("icp-slam") else 10.0
        assert rec["rel_trans_abs_mean"] < 0.5 and rec["rel_rot_abs_mean"] < rot, rec
    summary = result["summary"]
    icp = summary["algorithm"].astype(str).str.startswith("icp-slam")
    assert (summary.loc[icp, "rel_n_mean"] == 154).all() and icp.sum() == 1
