"""``slamq verdict``: several maps of one place judged without ground truth, from the
command line, on the real maps that ship in tests/data."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from slamq.verdict.maps import maps_verdict

OFFICE = Path(__file__).parents[1] / "data" / "slam_comparison_tools" / "test_results" / "office"


def slamq(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "slamq", *args], capture_output=True,
                          text=True, timeout=300)


def test_verdict_of_a_folder_names_what_the_library_names(tmp_path: Path) -> None:
    out = tmp_path / "v.json"
    r = slamq("verdict", str(OFFICE), "--json", str(out))
    assert r.returncode == 0, r.stderr
    data = json.loads(out.read_text())
    v = data["verdict"]
    assert v["basis"][0] == "agreement" and len(v["ranking"]) == 5
    # the office's cartographer map is the one the others do not confirm (it is never named)
    assert v["best"] is not None and v["best"] != "cartographer_map.yaml"
    assert v["ranking"][-1] == "cartographer_map.yaml"
    assert f"office: {v['best']} is best by agreement with the other maps" in r.stdout
    # the table lists every map in the verdict's order, with its support
    lines = [ln for ln in r.stdout.splitlines() if ln[:1].isdigit()]
    assert [ln.split()[1] for ln in lines] == v["ranking"]
    lib = maps_verdict(sorted(OFFICE.glob("*_map.yaml")))
    assert lib["verdict"]["ranking"] == v["ranking"]
    assert data["evidence"]["algorithms"][v["best"]]["support"] == pytest.approx(
        lib["evidence"]["algorithms"][v["best"]]["support"])


def test_a_bad_map_is_one_error_line_and_the_others_are_still_judged(tmp_path: Path) -> None:
    for f in OFFICE.glob("*_map.*"):
        shutil.copy(f, tmp_path / f.name)
    (tmp_path / "broken.pgm").write_bytes(b"P5\n10 10\n255\nshort")
    r = slamq("verdict", str(tmp_path))
    assert r.returncode == 2
    bad = [ln for ln in r.stderr.splitlines() if "broken.pgm" in ln]
    assert len(bad) == 1, r.stderr
    assert "is best by agreement" in r.stdout and "broken.pgm" not in r.stdout


def test_two_maps_are_not_enough_and_the_verdict_says_why(tmp_path: Path) -> None:
    r = slamq("verdict", str(OFFICE / "gmapping_map.yaml"), str(OFFICE / "slam_toolbox_map.yaml"),
              "--json", "-")
    assert r.returncode == 0, r.stderr
    v = json.loads(r.stdout)["verdict"]
    assert v["best"] is None and "fewer than three maps" in v["confidence"]
    assert "no algorithm is named best" in r.stderr


def test_a_wing_two_maps_draw_is_the_buildings_in_the_table(tmp_path: Path) -> None:
    """docs/spec.md section 9: a second wall direction another map draws too (a wing) is
    not held against either map, and the table and a note say so."""
    from slamq.synth import save_world, world

    w = world(534, kind="wing", resolution=0.1)
    paths = [str(save_world(w, tmp_path / f"{name}.yaml")) for name in ("a", "b")]
    r = slamq("verdict", *paths)
    assert r.returncode == 0, r.stderr
    rows = [ln for ln in r.stdout.splitlines() if ln.split()[:1] in (["1"], ["2"], ["-"])]
    assert len(rows) == 2 and all(ln.endswith("superposed (the building's)") for ln in rows), \
        r.stdout
    assert "second wall direction (31 deg from the first) is drawn by" in r.stdout
    assert "never named best: defects: superposed" not in r.stdout
