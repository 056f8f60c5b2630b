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
from slamq.results.formats import read_records as read_results
from slamq.sources import load_map

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
    table = out.out.strip().splitlines()
    assert table[0].split()[0] == "map" and table[1 + len(records)].startswith("lower is better")
    rows = list(csv.DictReader(cs.open()))
    assert [r["source"] for r in rows] == [r["source"] for r in records]
    for rec, row in zip(records, rows):
        q = slamq.evaluate(rec["source"])
        assert rec["corners"] == q.corners == int(row["corners"])
        assert rec["enclosed_areas"] == q.enclosed_areas == int(row["enclosed_areas"])
        assert math.isclose(float(row["occupied_fraction"]), q.occupied_fraction, rel_tol=1e-12)
        assert rec["param_sweep_step"] == 1
    # nav2's free_thresh 0.25 with 205 unknown is its own convention: no warning, and a
    # debug note per map with -v; the one warning about the maps is that cartographer's is
    # turned 2 degrees (issue 13's comparability check), and their canvases differ
    warned = [line for line in out.err.splitlines() if line.startswith("slamq: warning:")]
    assert "free_thresh" not in out.err
    # issue 42, point 5: the warning names each map with its angle, and speaks in flags
    assert any("turned differently (wall angles modulo 90: cartographer_map.yaml -2.1," in w
               and "(--canonical-resolution 0.07)" in w for w in warned), out.err
    assert all("not comparable" in w for w in warned), out.err
    assert main(["eval", str(OFFICE), "-v"]) == 0
    notes = [line for line in capsys.readouterr().err.splitlines()
             if line.startswith("slamq: debug:") and "free_thresh 0.25" in line]
    assert len(notes) == len(records)


def test_a_warning_repeated_for_other_files_is_shown_once_and_counted(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    for i in range(3):
        _room_pgm(tmp_path / f"m{i}.pgm")
        (tmp_path / f"m{i}.yaml").write_text(f"image: m{i}.pgm\nresolution: 0.05\n")
    assert main(["eval", str(tmp_path)]) == 0
    warn = [line for line in capsys.readouterr().err.splitlines()
            if line.startswith("slamq: warning:")]
    assert len(warn) == 2 and "has no 'origin'" in warn[0], warn
    assert "the same for 2 more file(s)" in warn[1]
    assert main(["eval", str(tmp_path), "-q"]) == 0
    assert capsys.readouterr().err == ""


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


def test_unknown_value_reaches_the_loader_for_every_path(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    room = _room_pgm(tmp_path / "room.pgm")                     # 205 outside the walls
    (tmp_path / "sub").mkdir()
    _room_pgm(tmp_path / "sub" / "twin.pgm")
    twin = tmp_path / "sub" / "twin.yaml"
    twin.write_text(
        "image: twin.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nfree_thresh: 0.25\n")
    js = tmp_path / "r.json"
    assert main(["eval", str(room), str(tmp_path / "sub"), "--unknown-value", "254",
                 "--json", str(js)]) == 0
    records = {Path(r["source"]).name: r for r in json.loads(js.read_text())}
    assert sorted(records) == ["room.pgm", "twin.yaml"]
    for rec in records.values():
        # 254 (the room's floor, 18 x 28) is unknown; 205 is known (and bright: free)
        assert rec["unknown"] == 18 * 28 and rec["known"] == 30 * 40 - 18 * 28
    assert records["room.pgm"]["known"] == load_map(room, unknown_value=254).known_count
    assert load_map(twin).known_count == 20 * 30  # without the option: 205 unknown


def test_a_map_with_no_known_cell_gives_nan_ratios_and_zero_counts(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    blank = tmp_path / "blank.pgm"
    blank.write_bytes(b"P5 4 3 255\n" + bytes([205] * 12))     # every cell unknown
    js, cs = tmp_path / "r.json", tmp_path / "r.csv"
    assert main(["eval", str(blank), "--json", str(js), "--csv", str(cs)]) == 0
    out = capsys.readouterr().out
    header, row = (line.split() for line in out.splitlines()[:2])
    assert row[-7:] == ["0", "0", "nan", "nan", "0", "0", "0"]  # known .. at u
    assert "canonical" not in out  # corners_canonical is off by default: no column, no legend
    (rec,) = read_results(js)
    assert "NaN" not in js.read_text()                          # valid JSON: null
    q = slamq.evaluate(blank)
    for name in ("occupied_fraction", "proportion", "threshold"):
        assert math.isnan(rec[name]) and math.isnan(getattr(q, name))
    assert (rec["known"], rec["occupied"], rec["free"], rec["corners"],
            rec["enclosed_areas"], rec["unknown"]) == (0, 0, 0, 0, 0, 12)
    (crow,) = list(csv.DictReader(cs.open()))
    assert math.isnan(float(crow["proportion"])) and crow["known"] == "0"
    assert list(crow) == list(q.to_dict())
    assert main(["eval", str(blank), "--canonical-resolution", "0.07"]) == 0
    out = capsys.readouterr().out
    header, row = (line.split() for line in out.splitlines()[:2])
    assert header[-3:-1] == ["canonical", "enclosed_areas"] and row[-3] == "0"  # no known cell
    assert "canonical: corners of the map turned" in " ".join(out.split())


def test_csv_and_json_without_results_keep_the_columns(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.pgm"
    bad.write_bytes(b"")
    js, cs = tmp_path / "r.json", tmp_path / "r.csv"
    assert main(["eval", str(bad), "--json", str(js), "--csv", str(cs)]) == 2
    assert json.loads(js.read_text()) == []
    q = slamq.evaluate(np.full((2, 2), 254, np.uint8))
    assert cs.read_text().strip().split(",") == list(q.to_dict())


def test_a_folder_with_a_symlink_loop_still_evaluates_the_rest(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    _room_pgm(tmp_path / "room.pgm")
    (tmp_path / "a.pgm").symlink_to(tmp_path / "b.pgm")
    (tmp_path / "b.pgm").symlink_to(tmp_path / "a.pgm")
    js = tmp_path / "r.json"
    assert main(["eval", str(tmp_path), "--json", str(js)]) == 2
    errors = capsys.readouterr().err.strip().splitlines()
    assert len(errors) == 2 and all("symbolic links" in e for e in errors), errors
    assert [Path(r["source"]).name for r in read_results(js)] == ["room.pgm"]


def test_an_unexpected_failure_on_one_map_costs_no_other_map(
        tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A bug (not a bad input) on one map: that map's line, the others' results, exit 1."""
    from slamq import native

    real = native.evaluate

    def flaky(values, *args):
        if values.shape == (3, 3):
            raise RuntimeError("simulated bug")
        return real(values, *args)

    monkeypatch.setattr(native, "evaluate", flaky)
    good = _room_pgm(tmp_path / "room.pgm")
    odd = tmp_path / "odd.pgm"
    odd.write_bytes(b"P5 3 3 255\n" + bytes(9))
    js = tmp_path / "r.json"
    assert main(["eval", str(good), str(odd), "--json", str(js)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"slamq: error: {odd}: unexpected RuntimeError: simulated bug"]
    assert [Path(r["source"]).name for r in read_results(js)] == ["room.pgm"]


def test_threads_below_one_is_exit_2_before_any_work(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    good = _room_pgm(tmp_path / "room.pgm")
    assert main(["eval", str(good), "--threads", "0"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--threads" in err[0]


def _slamq_without(module: str, *args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    """The real slamq command line in a fresh interpreter where ``module`` cannot be
    imported (as on a machine without that extra)."""
    code = (f"import sys; sys.modules[{module!r}] = None\n"
            "from slamq.cli import main\nsys.exit(main(sys.argv[1:]))")
    return subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True,
                          env=slamq_env(), timeout=120, cwd=cwd)


@pytest.mark.parametrize("command, extra, module", [
    (["report", "{results}", "--out", "{tmp}/site"], "report", "PIL"),
    (["timeline", "{tmp}/run.bag", "--out", "{tmp}/tl"], "report", "matplotlib"),
    (["batch", "{maps}", "--out", "{tmp}/r.jsonl", "--report", "{tmp}/site"], "report", "PIL"),
    (["eval", "{tmp}/run.bag"], "bags", "rosbags"),
])
def test_a_missing_extra_is_named_with_its_install_command_before_any_work(
        tmp_path: Path, command: list[str], extra: str, module: str) -> None:
    maps = tmp_path / "maps"
    maps.mkdir()
    _room_pgm(maps / "room.pgm")
    results = tmp_path / "r.json"
    results.write_text('[{"map": "room.pgm", "corners": 1}]')
    (tmp_path / "run.bag").write_bytes(b"#ROSBAG V2.0\n")
    args = [a.format(tmp=tmp_path, results=results, maps=maps) for a in command]
    proc = _slamq_without(module, *args)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and f"pip install 'slamq[{extra}]'" in lines[0], proc.stderr
    assert not (tmp_path / "site").exists() and not (tmp_path / "r.jsonl").exists()


def test_version_and_help_start_fast() -> None:
    import time

    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "slamq", "--version"], capture_output=True,
                          text=True, env=slamq_env(), timeout=60)
    elapsed = time.perf_counter() - t0
    assert proc.returncode == 0 and proc.stdout.startswith("slamq ")
    assert elapsed < 2.0  # a generous bound for a loaded CI machine; ~0.25 s measured


def test_eval_reads_stdin_and_writes_json_or_csv_to_stdout(tmp_path: Path) -> None:
    room = _room_pgm(tmp_path / "room.pgm")
    expected = slamq.evaluate(room)
    cmd = [sys.executable, "-m", "slamq", "eval", "-", "--json", "-"]
    proc = subprocess.run(cmd, input=room.read_bytes(), capture_output=True, env=slamq_env(),
                          timeout=120)
    assert proc.returncode == 0, proc.stderr
    (rec,) = json.loads(proc.stdout)  # stdout holds only the JSON; the table went to stderr
    assert rec["source"] == "<stdin>" and rec["corners"] == expected.corners
    assert b"occupied_fraction" in proc.stderr
    proc = subprocess.run([sys.executable, "-m", "slamq", "eval", str(room), "--csv", "-", "-q"],
                          capture_output=True, text=True, env=slamq_env(), timeout=120)
    (row,) = list(csv.DictReader(proc.stdout.splitlines()))
    assert int(row["corners"]) == expected.corners and proc.stderr == ""
    assert not (tmp_path / "-").exists() and not Path("-").exists()


def test_summary_and_report_read_what_eval_writes(tmp_path: Path) -> None:
    js, cs = tmp_path / "e.json", tmp_path / "e.csv"
    run = [sys.executable, "-m", "slamq"]
    proc = subprocess.run([*run, "eval", str(OFFICE), "--json", str(js), "--csv", str(cs)],
                          capture_output=True, text=True, env=slamq_env(), timeout=300)
    assert proc.returncode == 0, proc.stderr
    for results in (js, cs):
        proc = subprocess.run([*run, "summary", str(results)], capture_output=True, text=True,
                              env=slamq_env(), timeout=300)
        assert proc.returncode == 0, proc.stderr
        assert "gmapping_map" in proc.stdout or "all maps" in proc.stdout, proc.stdout
    proc = subprocess.run([*run, "report", str(cs), "--out", str(tmp_path / "site"),
                           "--no-gifs"], capture_output=True, text=True, env=slamq_env(),
                          timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "site" / "index.html").is_file()


def test_occupancy_map_repr_does_not_dump_arrays() -> None:
    m = load_map(OFFICE / "gmapping_map.yaml")
    text = repr(m)
    assert text.startswith("OccupancyMap(") and "array" not in text and len(text) < 200
    assert "608x896 cells" in text and "resolution=0.05" in text


def test_the_canonical_hint_goes_once_the_flag_is_given(capsys: pytest.CaptureFixture[str]
                                                        ) -> None:
    """Issue 42, point 5: with --canonical-resolution given, the turned-maps warning says to
    compare the canonical corners the maps now have, not to pass the flag."""
    assert main(["eval", str(OFFICE), "--canonical-resolution", "0.07", "-q"]) == 0
    err = capsys.readouterr().err
    turned = [ln for ln in err.splitlines() if "turned differently" in ln]
    assert turned and all("compare their corners_canonical" in ln
                          and "canonical-resolution" not in ln for ln in turned), err
