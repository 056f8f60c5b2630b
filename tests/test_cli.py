"""``slamq eval``: exit codes, the table, JSON and CSV contents, one bad file among good ones."""

from __future__ import annotations

import csv
import json
import math
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import TEST_DATA, slamq_env

import slamq
from slamq.cli import main

OFFICE = TEST_DATA / "slam_comparison_tools" / "test_results" / "office"


def _room_pgm(path: Path) -> Path:
    img = np.full((30, 40), 205, np.uint8)
    img[5:25, 5:35] = 0
    img[6:24, 6:34] = 254
    path.write_bytes(b"P5\n40 30\n255\n" + img.tobytes())
    return path


def test_eval_folder_json_csv(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    js, cs = tmp_path / "r.json", tmp_path / "r.csv"
    assert main(["eval", str(OFFICE), "--json", str(js), "--csv", str(cs)]) == 0
    out = capsys.readouterr()
    # five YAML maps; each image a YAML names is evaluated once, through the YAML
    records = json.loads(js.read_text())
    assert sorted(Path(r["source"]).name for r in records) == sorted(
        p.name for p in OFFICE.glob("*.yaml"))
    assert len(out.out.strip().splitlines()) == 1 + len(records)
    rows = list(csv.DictReader(cs.open()))
    assert [r["source"] for r in rows] == [r["source"] for r in records]
    for rec, row in zip(records, rows):
        q = slamq.evaluate(rec["source"])
        assert rec["corners"] == q.corners == int(row["corners"])
        assert rec["enclosed_areas"] == q.enclosed_areas == int(row["enclosed_areas"])
        assert math.isclose(float(row["occupied_fraction"]), q.occupied_fraction, rel_tol=1e-12)
        assert rec["param_sweep_step"] == 1
    # the nav2 205-rule warning: once in full, then counted
    warn = [line for line in out.err.splitlines() if line.startswith("slamq: warning:")]
    assert any("the same for 4 more file(s)" in line for line in warn), out.err


def test_one_bad_file_among_good_ones(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    good = _room_pgm(tmp_path / "room.pgm")
    bad = tmp_path / "broken.pgm"
    bad.write_bytes(b"P5\n400 300\n255\n" + b"\x00" * 100)  # truncated
    js = tmp_path / "r.json"
    assert main(["eval", str(good), str(bad), str(tmp_path / "missing.yaml"),
                 "--json", str(js)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    errors = [line for line in err if line.startswith("slamq: error:")]
    assert len(errors) == 2
    assert any("broken.pgm" in line for line in errors)
    assert any("missing.yaml" in line for line in errors)
    records = json.loads(js.read_text())
    assert [Path(r["source"]).name for r in records] == ["room.pgm"]
    assert records[0]["enclosed_areas"] == 1


def test_bad_parameter_is_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    good = _room_pgm(tmp_path / "room.pgm")
    assert main(["eval", str(good), "--sweep-step", "0"]) == 2
    assert "sweep_step" in capsys.readouterr().err


def test_empty_folder_is_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["eval", str(tmp_path)]) == 2
    assert "no map found" in capsys.readouterr().err


def test_curve_verify_and_parameters(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    good = _room_pgm(tmp_path / "room.pgm")
    js = tmp_path / "r.json"
    assert main(["eval", str(good), "--verify", "--curve", "--sweep-step", "64",
                 "--min-area", "2", "--json", str(js)]) == 0
    (rec,) = json.loads(js.read_text())
    assert rec["curve"] == [1, 1, 1, 1]  # u = 0, 64, 128, 192: the room is enclosed at each
    assert rec["param_min_area"] == 2
    assert "curve u:count_u 0:1 64:1 128:1 192:1" in capsys.readouterr().out


def test_console_entry_point(tmp_path: Path) -> None:
    """The real command in a subprocess: table on stdout, exit code 0, then 2 for bad input."""
    shutil.copy(OFFICE / "gmapping_map.pgm", tmp_path / "g.pgm")
    run = subprocess.run([sys.executable, "-m", "slamq", "eval", str(tmp_path / "g.pgm")],
                         capture_output=True, text=True, env=slamq_env(), timeout=120)
    assert run.returncode == 0, run.stderr
    assert "g.pgm" in run.stdout and "corners" in run.stdout
    (tmp_path / "x.yaml").write_text("image: [unclosed\n")
    run = subprocess.run([sys.executable, "-m", "slamq", "eval", str(tmp_path / "x.yaml")],
                         capture_output=True, text=True, env=slamq_env(), timeout=120)
    assert run.returncode == 2
    assert run.stderr.count("\n") == 1 and "x.yaml" in run.stderr
