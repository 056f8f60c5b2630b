"""A cut of a real log (the first 300 scans of MIT CSAIL, 154 relations) through
``slamq run``: converted with its own timestamps, mapped by icp-slam and rbpf-slam as in
examples/real2d.yaml, each estimate scored by the relations error of Kümmerle et al. 2009
(skipped without the data or MRPT)."""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np
import pytest
import yaml

import slamq
from slamq.runner import runner
from slamq.synth.writers.carmen_rawlog import carmen_to_rawlog

DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "datasets2d"
EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "real2d.yaml"
LOG = DATA / "mit-csail" / "mit-csail.clf"
RELATIONS = DATA / "mit-csail" / "mit-csail.relations"

pytestmark = pytest.mark.skipif(
    not LOG.exists() or not all(shutil.which(p) for p in ("rbpf-slam", "icp-slam")),
    reason="../shared/data/datasets2d or MRPT (apt-get install mrpt-apps) absent",
)


def test_real_log_cut_scored_by_relations(tmp_path: Path) -> None:
    rawlog = tmp_path / "csail300.rawlog"
    info = carmen_to_rawlog(LOG, rawlog, max_scans=300)
    assert info["scans"] == 300
    # the rawlog keeps the log's clock: its first stamp is the log's first FLASER stamp
    assert info["first"] == pytest.approx(1134864629.895182, abs=1e-6)
    cfg = yaml.safe_load(EXAMPLE.read_text())
    cfg["algorithms"] = {k: cfg["algorithms"][k] for k in ("icp-slam", "rbpf-slam")}
    cfg["algorithms"]["icp-slam"]["params"] = {"grid": [1]}
    cfg["algorithms"]["rbpf-slam"]["params"] = {"particles": [5]}
    cfg.update(sequences={"csail300": {"input": str(rawlog)}}, output=str(tmp_path / "runs"),
               base_dir=str(tmp_path), iterations=1, timeout=120)
    rows = runner.execute(cfg)
    assert len(rows) == 2
    assert all(r["outcome"] == "ok" for r in rows), [(r["algorithm"], r["reason"]) for r in rows]
    rel = slamq.load_relations(RELATIONS)
    for r in rows:
        res = slamq.relations(slamq.load_trajectory(r["trajectory"]), rel)
        # only the relations inside the cut are placed, each on a pose at its exact stamp
        assert res.n == 154 and res.n_interpolated == 0
        assert all(math.isfinite(getattr(res, s)) for s in
                   ("trans_abs_mean", "trans_abs_std", "rot_abs_mean", "trans_max"))
        # 300 scans of a log whose odometry alone is 0.053 m / 4.3 deg off here: a scan
        # matcher or filter that works stays within decimetres and a few degrees
        assert res.trans_abs_mean < 0.5 and res.rot_abs_mean < 6.0
        assert np.isfinite(res.trans_errors).all()
