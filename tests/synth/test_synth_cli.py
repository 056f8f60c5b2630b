"""``slamq synth world`` and ``slamq synth sequence``: files, exit codes, clear errors."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import slamq
from slamq.cli import main


def test_world_then_sequence(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["synth", "world", "--seed", "2", "--kind", "hall", "--size", "10", "8",
                 "--out", str(tmp_path / "w")]) == 0
    yaml = tmp_path / "w" / "hall_2.yaml"
    assert yaml.is_file() and (tmp_path / "w" / "hall_2_transparent.png").is_file()
    assert slamq.load_map(yaml).shape == (180, 220)
    assert main(["synth", "sequence", str(yaml), "--noise", "none", "--seed", "1",
                 "--out", str(tmp_path / "s"), "--formats", "truth,npz", "--beams", "181",
                 "--length", "10"]) == 0
    out = capsys.readouterr().out
    assert "hall_2-s1-none" in out
    names = {p.name for p in (tmp_path / "s").iterdir()}
    assert {"gt_map.yaml", "gt_map.pgm", "visible_map.yaml", "visible_map.pgm", "gt.tum",
            "odom.tum", "sequence.json", "sequence.npz"} <= names
    doc = json.loads((tmp_path / "s" / "sequence.json").read_text())
    assert doc["laser"]["beams"] == 181 and doc["meta"]["world"]["kind"] == "hall"


def test_a_benchmark_of_worlds(tmp_path: Path, capsys) -> None:
    assert main(["synth", "world", "--kind", "all", "--count", "7", "--seed", "10",
                 "--resolution", "0.2", "--out", str(tmp_path)]) == 0
    names = sorted(p.name for p in tmp_path.glob("*.yaml"))
    # every kind in turn, the later hexagonal one too
    assert names == sorted(["office_10.yaml", "loop_11.yaml", "corridor_12.yaml",
                            "hall_13.yaml", "symmetric_14.yaml", "mixed_15.yaml",
                            "hexagonal_16.yaml"])
    assert main(["synth", "world", "--count", "2", "--name", "x", "--out",
                 str(tmp_path)]) == 2


def test_any_map_server_map_is_a_world(tmp_path: Path, test_data: Path) -> None:
    gt = test_data / "slam_comparison_tools/ground_truths/office_ground_truth.yaml"
    assert main(["synth", "sequence", str(gt), "--out", str(tmp_path), "--beams", "91",
                 "--length", "20"]) == 0
    doc = json.loads((tmp_path / "sequence.json").read_text())
    assert doc["name"].startswith("office_ground_truth-s0-low")


@pytest.mark.parametrize("argv, message", [
    (["synth", "sequence", "{tmp}/missing.yaml", "--out", "{tmp}/o"], "missing.yaml"),
    (["synth", "sequence", "{tmp}/junk.yaml", "--out", "{tmp}/o"], "junk.yaml"),
    (["synth", "sequence", "{tmp}/w/office_0.yaml", "--out", "{tmp}/o", "--formats", "gif"],
     "unknown format 'gif'"),
    (["synth", "sequence", "{tmp}/w/office_0.yaml", "--out", "{tmp}/o", "--beams", "0"],
     "--beams"),
    (["synth", "sequence", "{tmp}/w/office_0.yaml", "--out", "{tmp}/o", "--clearance", "9"],
     "office_0.yaml: "),
    (["synth", "sequence", "{tmp}/w/office_0.yaml", "--out", "{tmp}/junk.yaml"],
     "not a folder"),
])
def test_bad_input_exits_2_naming_the_file(tmp_path: Path, capsys, argv, message) -> None:
    main(["synth", "world", "--size", "8", "6", "--out", str(tmp_path / "w")])
    (tmp_path / "junk.yaml").write_text("just text\n")
    capsys.readouterr()
    assert main([a.format(tmp=tmp_path) for a in argv]) == 2
    err = capsys.readouterr().err
    assert err.startswith("slamq: error:") and message in err


def test_the_help_names_the_writers_formats() -> None:
    from slamq.cli.synth import WRITER_FORMATS
    from slamq.synth.writers import FORMATS

    assert WRITER_FORMATS == tuple(FORMATS)


def test_sensor_log_formats_go_to_the_writers(tmp_path: Path, capsys) -> None:
    main(["synth", "world", "--size", "8", "6", "--out", str(tmp_path / "w")])
    world = str(tmp_path / "w" / "office_0.yaml")
    assert main(["synth", "sequence", world, "--out", str(tmp_path / "o"), "--beams", "31",
                 "--formats", "truth,rawlog,carmen", "--length", "8"]) == 0
    out = capsys.readouterr().out
    assert "rawlog: " in out and "carmen: " in out
    assert sorted(p.suffix for p in (tmp_path / "o").glob("*.rawlog")) == [".rawlog"]
    assert len(list((tmp_path / "o").glob("*.log"))) == 1
    assert main(["synth", "sequence", world, "--out", str(tmp_path / "o2"),
                 "--formats", "truth,video"]) == 2
    assert "unknown format 'video': one of truth, npz, rawlog, carmen, rosbag1" in \
        capsys.readouterr().err
    assert not (tmp_path / "o2").exists()  # nothing simulated before the check
