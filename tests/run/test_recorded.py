"""Recorded sequences (``carmen:`` / ``bag:``) and relations ground truth in ``slamq run``:
the config's checks, the conversion done once (and again only when the log changes), the
node sidecars the runs' ``times:`` name, trajectories whose stamps go backwards
(``unsorted:``), and the ``rel_*`` columns of the scores (rescored when the relations
file changes). Small CARMEN logs written here; programs are Python one-liners."""

from __future__ import annotations

import json
import math
import os
import re
import sys
from pathlib import Path

import numpy as np
import pytest

from slamq.errors import ParamError, SequenceError, TrajectoryError
from slamq.runner import runner
from slamq.runner.config import load_config
from slamq.runner.planning import prepare_inputs
from slamq.synth.writers.rawlog import graphslam_nodes

PY = sys.executable
T0 = 1_000_000.0


def _stamps(n: int, back: tuple[int, ...] = ()) -> list[float]:
    """Scan stamps 0.25 s apart; at each index of ``back`` the stamp runs 0.1 s back (a
    scan logged after one stamped later, as in the Intel log)."""
    t = [T0 + 0.25 * i for i in range(n)]
    for i in back:
        t[i], t[i - 1] = t[i - 1] + 0.15, t[i - 1]
        t[i], t[i - 1] = t[i - 1] - 0.1, t[i]
    return t


def write_log(path: Path, n: int = 20, back: tuple[int, ...] = (), bad_line: int = 0) -> Path:
    """A CARMEN log of ``n`` FLASER scans (5 beams), the robot driving 0.2 m a scan along x
    and turning 0.1 rad every fourth scan."""
    lines = ["PARAM robot_front_laser_max 8.0 0 h 0"]
    yaw = 0.0
    for i, t in enumerate(_stamps(n, back)):
        yaw += 0.1 if i % 4 == 3 else 0.0
        x = 0.2 * i
        pose = f"{x:.6f} 0.000000 {yaw:.6f}"
        lines.append(f"FLASER 5 1.0 2.0 3.0 2.0 1.0 {pose} {pose} {t:.6f} h {t:.6f}")
    if bad_line:
        lines[bad_line - 1] = "FLASER 5 1.0 2.0"
    path.write_text("\n".join(lines) + "\n")
    return path


def _config(tmp_path: Path, seq: dict, algorithms: dict | None = None, **extra) -> dict:
    return {"base_dir": str(tmp_path), "output": "out", "report": False,
            "sequences": {"log": seq},
            "algorithms": algorithms or {"noop": {"command": [PY, "-c", "pass"]}}, **extra}


def _graph(spacing: list[float]) -> dict:
    """graphslam-engine's outputs: node poses timed by a node sidecar per spacing."""
    return {"g": {"command": [PY, "-c", "pass"], "params": {"spacing": spacing},
                  "outputs": {"trajectory": {"path": "graph.graph", "format": "mrpt",
                                             "times": "{input}.nodes-{param.spacing}m.txt"}}}}


# ------------------------------------------------------------------------ the config

def test_a_recorded_sequence_with_a_wrong_key_is_refused(tmp_path: Path) -> None:
    log = write_log(tmp_path / "a.clf")
    rel = tmp_path / "a.relations"
    rel.write_text(f"{T0} {T0 + 1} 0.8 0 0 0 0 0\n")
    cases = [
        ({"carmen": "a.clf", "max_scan": 3},
         "sequences.log: unknown key 'max_scan' (did you mean 'max_scans'?)"),
        ({"carmen": "a.clf", "scan_topic": "/scan"}, "unknown key 'scan_topic'"),
        ({"carmen": "a.clf", "input": "a.rawlog"},
         "needs exactly one of input, carmen, bag (or a synth recipe); found input and carmen"),
        ({"carmen": "a.clf", "bag": "a.bag"}, "found carmen and bag"),
        ({"carmen": "missing.clf"}, "sequences.log.carmen: "),
        ({"bag": "missing.bag"}, "missing.bag: no such bag"),
        ({"carmen": "a.clf", "relations": "b.relations"}, "b.relations: no such relations file"),
        ({"carmen": "a.clf", "laser": "side"}, "sequences.log.laser must be one of front, rear"),
        ({"carmen": "a.clf", "odometry": "gps"}, "odometry must be one of auto, odom"),
        ({"carmen": "a.clf", "max_scans": 0}, "max_scans must be a whole number >= 1"),
        ({"carmen": "a.clf", "max_scans": 2.5}, "max_scans must be a whole number >= 1"),
        ({"carmen": "a.clf", "motion_model": {"a11": 1}},
         "motion_model: unknown key 'a11' (did you mean 'a1'?)"),
        ({"carmen": "a.clf", "motion_model": {"a1": -1}}, "motion_model.a1 must be a number"),
        ({"carmen": "a.clf", "unsorted": "yes"}, "unsorted must be one of error, last, sort"),
        ({"input": "a.clf", "relations": "a.relations", "unsorted": "sort", "max_scans": 3},
         "unknown key 'max_scans'"),
    ]
    for seq, message in cases:
        with pytest.raises(ParamError, match=re.escape(message)):
            load_config(_config(tmp_path, seq))
    with pytest.raises(ParamError, match=re.escape(f"{tmp_path / 'missing.clf'}: no such "
                                                   "CARMEN log")):
        load_config(_config(tmp_path, {"carmen": "missing.clf"}))
    cfg = load_config(_config(tmp_path, {"carmen": "a.clf", "relations": "a.relations",
                                         "max_scans": 5, "unsorted": "sort",
                                         "motion_model": {"a1": 0.05}}))
    s = cfg.sequences[0]
    assert s.input == tmp_path / "out" / "sequences" / "log" / "log.rawlog"
    assert (s.relations, s.unsorted, s.recorded.source) == (rel, "sort", log)
    assert s.recorded.options == {"max_scans": 5, "motion_model": {"a1": 0.05}}
    # a plain sequence takes relations and unsorted too
    plain = load_config(_config(tmp_path, {"input": "a.clf", "relations": "a.relations",
                                           "unsorted": "last"})).sequences[0]
    assert (plain.relations, plain.unsorted, plain.recorded) == (rel, "last", None)


def test_a_times_file_the_conversion_does_not_write_is_refused(tmp_path: Path) -> None:
    write_log(tmp_path / "a.clf")
    algo = _graph([0.5])
    algo["g"]["outputs"]["trajectory"]["times"] = "{input}.nodes-{param.spacing}.txt"
    with pytest.raises(ParamError, match=re.escape(
            "log.rawlog.nodes-0.5.txt is not a file that sequence log (a carmen: log) is "
            "converted with")):
        runner.execute(_config(tmp_path, {"carmen": "a.clf"}, algo))
    assert not (tmp_path / "out" / "sequences" / "log").exists()  # before any conversion


# ------------------------------------------------------------------------ the conversion

def _mtime(p: Path) -> int:
    return p.stat().st_mtime_ns


def test_a_carmen_log_is_converted_once_with_its_node_sidecars(tmp_path: Path) -> None:
    log = write_log(tmp_path / "a.clf", n=20)
    doc = _config(tmp_path, {"carmen": "a.clf"}, _graph([0.5, 1.0]))
    # a dry run converts nothing: its keys come from the recipe
    rows = runner.execute(doc, dry_run=True)
    assert [r["outcome"] for r in rows] == ["planned", "planned"]
    assert not (tmp_path / "out" / "sequences").exists()
    cfg = load_config(doc)
    prepare_inputs(cfg)
    folder = tmp_path / "out" / "sequences" / "log"
    rawlog = folder / "log.rawlog"
    stamps = np.loadtxt(f"{rawlog}.steps.txt")
    np.testing.assert_array_equal(stamps, _stamps(20))  # the log's own clock, to the us
    # the odometry as the log prints it (6 decimals)
    odom = np.array([[float(f"{v:.6f}") for v in (0.2 * i, 0.0, 0.1 * ((i + 1) // 4))]
                     for i in range(20)])
    for m in (0.5, 1.0):
        want = stamps[graphslam_nodes(odom, m, math.radians(30.0))]
        got = np.loadtxt(f"{rawlog}.nodes-{m}m.txt")
        np.testing.assert_array_equal(got, want)
        assert len(got) < 20
    assert len(np.loadtxt(f"{rawlog}.nodes-1.0m.txt")) < len(np.loadtxt(f"{rawlog}.nodes-0.5m.txt"))
    info = json.loads((folder / "conversion.json").read_text())
    assert (info["scans"], info["first"], info["last"], info["backwards"]) == \
        (20, T0, T0 + 4.75, 0)
    before = _mtime(rawlog)
    # again: nothing converted; touched but the same bytes: nothing either
    prepare_inputs(load_config(doc))
    os.utime(log, ns=(before + 10**9, before + 10**9))
    prepare_inputs(load_config(doc))
    assert _mtime(rawlog) == before
    # a new node spacing: only its sidecar is written
    prepare_inputs(load_config(_config(tmp_path, {"carmen": "a.clf"}, _graph([0.5, 2.0]))))
    assert _mtime(rawlog) == before and (folder / "log.rawlog.nodes-2.0m.txt").is_file()
    # the log changed: converted again
    write_log(log, n=24)
    prepare_inputs(load_config(doc))
    assert json.loads((folder / "conversion.json").read_text())["scans"] == 24
    assert len(np.loadtxt(f"{rawlog}.steps.txt")) == 24
    assert not (folder / "log.rawlog.nodes-2.0m.txt").exists()  # made from the old log
    # other options: converted again
    prepare_inputs(load_config(_config(tmp_path, {"carmen": "a.clf", "max_scans": 7})))
    assert len(np.loadtxt(f"{rawlog}.steps.txt")) == 7


def test_a_log_that_cannot_be_converted_fails_before_any_run(tmp_path: Path) -> None:
    write_log(tmp_path / "a.clf", bad_line=4)
    algo = {"mark": {"command": [PY, "-c", "open('ran', 'w')"]}}
    with pytest.raises(SequenceError, match=re.escape(f"{tmp_path / 'a.clf'}:4: malformed "
                                                      "FLASER line")):
        runner.execute(_config(tmp_path, {"carmen": "a.clf"}, algo))
    assert not list(tmp_path.rglob("ran"))
    assert not (tmp_path / "out" / "sequences" / "log" / "conversion.json").exists()
    (tmp_path / "b.clf").write_text("PARAM x 1 0 h 0\nODOM 0 0 0 0 0 0 1.0 h 1.0\n")
    with pytest.raises(SequenceError, match="no laser scans to convert"):
        runner.execute(_config(tmp_path, {"carmen": "b.clf"}, algo))
    # the command line says so in one line, exit 2
    from slamq.cli import main

    cfg = tmp_path / "run.yaml"
    cfg.write_text(json.dumps(_config(tmp_path, {"carmen": "a.clf"}, algo)))
    assert main(["run", str(cfg)]) == 2


def test_a_malformed_relations_file_fails_before_any_run(tmp_path: Path) -> None:
    write_log(tmp_path / "a.clf")
    (tmp_path / "a.relations").write_text(f"{T0} {T0 + 1} 0.8 0 0 0 0\n")
    algo = {"mark": {"command": [PY, "-c", "open('ran', 'w')"]}}
    with pytest.raises(TrajectoryError, match=re.escape(
            f"{tmp_path / 'a.relations'}: line 1: 7 fields")):
        runner.execute(_config(tmp_path, {"carmen": "a.clf", "relations": "a.relations"},
                               algo))
    assert not list(tmp_path.rglob("ran"))


# ------------------------------------------------------------------- stamps going backwards

#: An icp-slam-like program: one pose per scan, ``index x y yaw``, the robot's x from the
#: log's odometry (0.2 m a scan), timed by the steps sidecar.
_ICP = ("import sys; n = len(open(sys.argv[1] + '.steps.txt').read().split()); "
        "open(sys.argv[2] + '/path.txt', 'w').write(''.join(f'{i} {0.2 * i} 0 0\\n' "
        "for i in range(n)))")


def _icp() -> dict:
    return {"icp": {"command": [PY, "-c", _ICP, "{input}", "{out}"],
                    "outputs": {"trajectory": {"path": "path.txt", "format": "mrpt",
                                               "times": "{input}.steps.txt"}}}}


def test_stamps_that_go_backwards_are_refused_or_sorted_as_the_sequence_says(
        tmp_path: Path) -> None:
    write_log(tmp_path / "a.clf", n=12, back=(4, 9))
    rows = runner.execute(_config(tmp_path, {"carmen": "a.clf"}, _icp()))
    assert rows[0]["outcome"] == "no_output"
    assert "non-monotonic timestamps" in rows[0]["reason"]
    assert "sequences.log.unsorted: sort reads it in time order" in rows[0]["reason"]
    info = json.loads((tmp_path / "out" / "sequences" / "log" / "conversion.json").read_text())
    assert info["backwards"] == 2  # the rawlog keeps the log's order
    rows = runner.execute(_config(tmp_path, {"carmen": "a.clf", "unsorted": "sort"}, _icp(),
                                  output="sorted"))
    assert rows[0]["outcome"] == "ok"
    tum = np.loadtxt(rows[0]["trajectory"])
    assert (np.diff(tum[:, 0]) > 0).all()
    # each pose keeps its own scan's time: the pose of scan i (x = 0.2 i) at stamp i
    stamps = _stamps(12, back=(4, 9))
    want = sorted((t, 0.2 * i) for i, t in enumerate(stamps))
    np.testing.assert_allclose(tum[:, :2], want, rtol=0, atol=1e-9)
    # last: only the poses after the last jump back
    rows = runner.execute(_config(tmp_path, {"carmen": "a.clf", "unsorted": "last"}, _icp(),
                                  output="last"))
    assert rows[0]["outcome"] == "ok" and len(np.loadtxt(rows[0]["trajectory"])) == 3


def test_rbpf_logs_whose_times_go_backwards_read_by_the_unsorted_rule(tmp_path: Path) -> None:
    from slamq.sources.mrpt import read_mrpt_path

    p = tmp_path / "log_estimated_path.txt"
    p.write_text("0 0 0 0 0 0 0 10.0\n1 1 0 0 0 0 0 10.5\n2 2 0 0 0 0 0 10.25\n"
                 "3 3 0 0 0 0 0 10.75\n")
    with pytest.raises(TrajectoryError, match="non-monotonic timestamps: pose 3"):
        read_mrpt_path(p)
    t = read_mrpt_path(p, unsorted="sort")
    assert t.timestamps.tolist() == [10.0, 10.25, 10.5, 10.75]
    assert t.positions[:, 0].tolist() == [0.0, 2.0, 1.0, 3.0]
    assert read_mrpt_path(p, unsorted="last").positions[:, 0].tolist() == [2.0, 3.0]
    # slamq.load_trajectory tells it from TUM (whose last column is a quaternion's w), so
    # the step index is not taken for the time, and applies the same rule
    import slamq

    with pytest.raises(TrajectoryError, match="non-monotonic timestamps: pose 3"):
        slamq.load_trajectory(p)
    t = slamq.load_trajectory(p, unsorted="sort")
    assert t.meta["format"] == "mrpt" and t.timestamps.tolist() == [10.0, 10.25, 10.5, 10.75]
    tum = tmp_path / "t.txt"
    tum.write_text("0 0 0 0 0 0 0 1\n1 1 0 0 0 0 0 1\n2 2 0 0 0 0 0.6 0.8\n")
    assert slamq.load_trajectory(tum).meta["format"] == "tum"


# ------------------------------------------------------------------------ relations scoring

#: A program that maps and logs the odometry exactly, as TUM (one pose per scan, the log's
#: clock): a 20 x 20 map with a wall, and ``t x y z qx qy qz qw`` lines.
_EXACT = r"""
import math, sys
rawlog, out = sys.argv[1], sys.argv[2]
stamps = [float(s) for s in open(rawlog + '.steps.txt').read().split()]
yaw = 0.0
lines = []
for i, t in enumerate(stamps):
    yaw += 0.1 if i % 4 == 3 else 0.0
    lines.append(f'{t:.6f} {0.2 * i} 0 0 0 0 {math.sin(yaw / 2)} {math.cos(yaw / 2)}\n')
open(out + '/traj.tum', 'w').write(''.join(lines))
img = bytearray([254] * 400)
img[200:220] = bytes(20)
open(out + '/map.pgm', 'wb').write(b'P5 20 20 255\n' + bytes(img))
open(out + '/map.yaml', 'w').write('image: map.pgm\nresolution: 0.05\norigin: [0, 0, 0]\n'
                                   'negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n')
"""


def _relations(path: Path, extra: float) -> Path:
    """Relations between scans 2 and 6, 6 and 10 (true motions of the log's odometry), the
    second's x off by ``extra``."""
    t = _stamps(20)
    yaw = np.cumsum([0.1 if i % 4 == 3 else 0.0 for i in range(20)])

    def motion(i: int, j: int) -> tuple[float, float, float]:
        dx = 0.2 * (j - i)
        c, s = math.cos(yaw[i]), math.sin(yaw[i])
        return c * dx, -s * dx, yaw[j] - yaw[i]

    rows = []
    for (i, j), off in (((2, 6), 0.0), ((6, 10), extra)):
        x, y, th = motion(i, j)
        rows.append(f"{t[i]:.6f} {t[j]:.6f} {x + off:.9f} {y:.9f} 0 0 0 {th:.9f}")
    path.write_text("\n".join(rows) + "\n")
    return path


def test_runs_of_a_sequence_with_relations_get_the_rel_columns(tmp_path: Path) -> None:
    import pandas as pd

    write_log(tmp_path / "a.clf", n=20)
    rel = _relations(tmp_path / "a.relations", extra=0.1)
    algo = {"exact": {"command": [PY, "-c", _EXACT, "{input}", "{out}"],
                      "outputs": {"map": {"path": "map.yaml", "format": "yaml"},
                                  "trajectory": {"path": "traj.tum", "format": "tum"}}}}
    doc = _config(tmp_path, {"carmen": "a.clf", "relations": "a.relations"}, algo,
                  iterations=2)
    result = runner.run(doc)
    recs = [json.loads(line) for line in (tmp_path / "out" / "results.jsonl").open()]
    assert len(recs) == 2
    for r in recs:
        assert r["error"] is None and r["rel_error"] is None, r
        assert r["relations"] == str(rel)
        assert (r["rel_n"], r["rel_n_relations"], r["rel_n_unplaced"]) == (2, 2, 0)
        assert r["rel_trans_abs_mean"] == pytest.approx(0.05, abs=1e-6)  # (0 + 0.1) / 2
        assert r["rel_trans_max"] == pytest.approx(0.1, abs=1e-6)
        assert r["rel_rot_abs_mean"] == pytest.approx(0.0, abs=1e-4)
    summary = pd.read_csv(tmp_path / "out" / "summary.csv")
    assert summary.loc[0, "rel_trans_abs_mean_mean"] == pytest.approx(0.05, abs=1e-6)
    assert summary.loc[0, "rel_n_mean"] == 2
    # the relations file changed: every run is scored again, and says why
    _relations(rel, extra=0.3)
    result = runner.run(doc)
    stage = next(s for s in result["stages"] if s["stage"] == "score")
    assert stage["done"] == 2 and "relations file changed" in stage["message"]
    recs = [json.loads(line) for line in (tmp_path / "out" / "results.jsonl").open()]
    assert [r["rel_trans_max"] for r in recs] == pytest.approx([0.3, 0.3], abs=1e-6)
    # unchanged: nothing scored
    stage = next(s for s in runner.run(doc)["stages"] if s["stage"] == "score")
    assert stage["done"] == 0
