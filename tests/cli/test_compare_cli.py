"""``slamq compare EST... --gt GT``: the table, JSON and CSV, overlays, exit codes."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import cv2
import numpy as np
import pytest
from conftest import TEST_DATA

from slamq.cli import main

ROOT = TEST_DATA / "slam_comparison_tools"
OFFICE = ROOT / "test_results" / "office"
GT = ROOT / "ground_truths" / "office_ground_truth.yaml"


def test_table_json_csv_and_overlays(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    js, cs, ov = tmp_path / "r.json", tmp_path / "r.csv", tmp_path / "overlays"
    code = main(["compare", str(OFFICE), "--gt", str(GT), "--json", str(js), "--csv", str(cs),
                 "--overlay", str(ov)])
    assert code == 0
    out = capsys.readouterr().out
    assert "gmapping_map.yaml" in out and "precision" in out and "dyaw (deg)" in out
    rows = json.loads(js.read_text())
    algos = sorted(Path(r["estimate"]).stem for r in rows)
    assert algos == sorted(p.stem for p in OFFICE.glob("*.yaml"))
    by = {Path(r["estimate"]).stem: r for r in rows}
    assert by["slam_toolbox_map"]["f1"] > 0.98 > by["cartographer_map"]["f1"]
    assert all(r["ground_truth"] == str(GT) and r["align"] == "icp" for r in rows)
    with open(cs, newline="") as fh:
        table = list(csv.DictReader(fh))
    assert len(table) == 5 and float(table[0]["tolerance"]) == pytest.approx(0.1)
    pngs = sorted(ov.glob("*.png"))
    assert len(pngs) == 5
    img = cv2.imread(str(pngs[0]))
    gt_shape = cv2.imread(str(GT.with_suffix(".pgm")), cv2.IMREAD_GRAYSCALE).shape
    assert img.shape[0] % gt_shape[0] == 0 and img.shape[1] % gt_shape[1] == 0
    # matched walls green, and (cartographer) ghost walls blue and missing walls red
    carto = cv2.imread(str(next(p for p in pngs if "cartographer" in p.name)))[:, :, ::-1]
    colours = {tuple(c) for c in carto.reshape(-1, 3)}
    assert {(0, 150, 0), (220, 0, 0), (30, 80, 230)} <= colours


def test_json_to_stdout_and_options(capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["compare", str(OFFICE / "gmapping_map.yaml"), "--gt", str(GT), "--json", "-",
                 "--align", "origin", "--tolerance", "0.15", "--max-distance", "1"])
    assert code == 0
    captured = capsys.readouterr()
    rows = json.loads(captured.out)
    assert len(rows) == 1 and rows[0]["align"] == "origin" and rows[0]["tolerance"] == 0.15
    assert rows[0]["max_distance"] == 1.0 and rows[0]["icp_rms"] is None
    assert "gmapping_map.yaml" in captured.err  # the table went to stderr


def test_the_ground_truth_in_the_folder_is_skipped(tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["compare", str(ROOT), "--gt", str(GT), "--json", "-", "-q"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert len(rows) == 5 and all("ground_truth" not in Path(r["estimate"]).name for r in rows)


def test_a_bad_map_among_good_ones_exits_2(tmp_path: Path,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "broken.pgm"
    bad.write_bytes(b"P5\n10 10\n255\n" + b"\x00" * 5)
    code = main(["compare", str(bad), str(OFFICE / "gmapping_map.yaml"), "--gt", str(GT),
                 "--json", str(tmp_path / "r.json")])
    assert code == 2
    err = capsys.readouterr().err
    assert "slamq: error:" in err and "broken.pgm" in err
    assert len(json.loads((tmp_path / "r.json").read_text())) == 1


def test_a_bad_ground_truth_exits_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["compare", str(OFFICE / "gmapping_map.yaml"), "--gt", str(tmp_path / "no.yaml")])
    assert code == 2
    assert "no.yaml" in capsys.readouterr().err


@pytest.mark.parametrize("args", [["--tolerance", "-1"], ["--threads", "0"],
                                  ["--occupied-threshold", "2"]])
def test_bad_options_exit_2(args: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    code = main(["compare", str(OFFICE / "gmapping_map.yaml"), "--gt", str(GT), *args])
    assert code == 2
    assert "slamq: error:" in capsys.readouterr().err


def test_an_unknown_alignment_is_refused_by_the_parser() -> None:
    with pytest.raises(SystemExit) as exc:
        main(["compare", "a.yaml", "--gt", "b.yaml", "--align", "best"])
    assert exc.value.code == 2


def test_arrays_written_as_images(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    gt = np.full((40, 40), 254, np.uint8)
    gt[10, 5:35] = 0
    cv2.imwrite(str(tmp_path / "gt.pgm"), gt)
    cv2.imwrite(str(tmp_path / "est.pgm"), gt)
    assert main(["compare", str(tmp_path / "est.pgm"), "--gt", str(tmp_path / "gt.pgm"),
                 "--json", "-"]) == 0
    (row,) = json.loads(capsys.readouterr().out)
    assert row["f1"] == 1.0 and row["ne"] == 0.0


def test_a_poor_fit_is_a_warning_naming_the_map(capsys: pytest.CaptureFixture[str]) -> None:
    """cartographer's office map fits the ground truth poorly by its frame: the warning line
    names the map, both fits and the CLI flag; --align auto keeps the better fit."""
    carto = OFFICE / "cartographer_map.yaml"
    assert main(["compare", str(carto), str(OFFICE / "gmapping_map.yaml"), "--gt", str(GT),
                 "--json", "-"]) == 0
    captured = capsys.readouterr()
    warnings = [ln for ln in captured.err.splitlines() if ln.startswith("slamq: warning:")]
    assert len(warnings) == 1 and str(carto) in warnings[0]
    assert "icp fits poorly (precision 0.265" in warnings[0] and "--align search" in warnings[0]
    rows = {Path(r["estimate"]).stem: r for r in json.loads(captured.out)}
    assert rows["cartographer_map"]["align"] == "icp" and rows["gmapping_map"]["note"] == ""
    assert main(["compare", str(carto), "--gt", str(GT), "--json", "-", "--align", "auto"]) == 0
    captured = capsys.readouterr()
    (row,) = json.loads(captured.out)
    assert row["align"] == "search" and row["precision"] > 0.5 and "--align" not in captured.err
