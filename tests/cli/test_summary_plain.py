"""``slamq summary`` without pandas (issue 42 point 11): the same table, CSV and JSON as the
pandas path, the same numbers to the last bit, and none of the heavy imports."""

from __future__ import annotations

import io
import json
import math
import random
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import TEST_DATA, slamq_env
from rich.console import Console

from slamq.cli import main
from slamq.results.formats import _results_table, read_records, read_results
from slamq.results.summary import (
    comparability_warnings,
    spreadsheet_safe,
    summarize,
    summary_rows,
    summary_table,
)

TOOLS = TEST_DATA / "slam_comparison_tools"


@pytest.fixture(scope="module")
def shipped(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The shipped office world as every results format ``slamq summary`` reads: the
    batch's JSON Lines (six maps with ATE and ground-truth columns), its Parquet, and
    ``slamq eval``'s JSON and CSV of the five SLAM maps."""
    d = tmp_path_factory.mktemp("summary")
    files = {"jsonl": d / "office.jsonl", "parquet": d / "office.parquet",
             "json": d / "eval.json", "csv": d / "eval.csv"}
    for fmt in ("jsonl", "parquet"):
        assert main(["batch", str(TOOLS), "--out", str(files[fmt]), "-q"]) == 0
    assert main(["eval", str(TOOLS / "test_results" / "office"), "--json", str(files["json"]),
                 "--csv", str(files["csv"]), "-q"]) == 0
    return files


def _slamq(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "slamq", *args], capture_output=True,
                          text=True, env=slamq_env(), timeout=120)


def _pandas_path_table(path: Path, ddof: int) -> str:
    """The table as ``slamq summary`` printed it before: read into a DataFrame
    (Arrow and pandas), summarised from the DataFrame."""
    buf = io.StringIO()
    Console(file=buf, width=160).print(
        summary_table(summarize(read_results(path), ddof=ddof, check_settings=False),
                      title=str(path)))
    return buf.getvalue()


@pytest.mark.parametrize("fmt", ["jsonl", "parquet", "json", "csv"])
@pytest.mark.parametrize("ddof", [0, 1])
def test_summary_prints_and_writes_what_the_pandas_path_does(
        shipped: dict[str, Path], tmp_path: Path, fmt: str, ddof: int) -> None:
    path = shipped[fmt]
    csv_out, json_out = tmp_path / "s.csv", tmp_path / "s.json"
    proc = _slamq("summary", str(path), "--ddof", str(ddof), "--csv", str(csv_out),
                  "--json", str(json_out))
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout == _pandas_path_table(path, ddof)
    assert "± " in proc.stdout or ddof == 1  # one run per algorithm: std only at ddof 0
    frame = summarize(read_results(path), ddof=ddof, check_settings=False)
    spreadsheet_safe(frame).to_csv(tmp_path / "p.csv", index=False)
    frame.to_json(tmp_path / "p.json", orient="records", indent=1)
    assert csv_out.read_bytes() == (tmp_path / "p.csv").read_bytes()
    assert json_out.read_bytes() == (tmp_path / "p.json").read_bytes()
    # the comparability warnings (turned maps, canvases) as the DataFrame gives them
    said = [line.removeprefix("slamq: warning: ") for line in proc.stderr.splitlines()]
    assert said and all(line.startswith("office: ") or line.startswith("all maps: ")
                        for line in said), proc.stderr
    assert len(said) == len(comparability_warnings(read_results(path)))


def test_summary_imports_neither_pandas_nor_numpy(shipped: dict[str, Path]) -> None:
    code = (
        "import sys\n"
        "from slamq.cli import main\n"
        f"rc = main(['summary', {str(shipped['jsonl'])!r}, '-q'])\n"
        "heavy = ('pandas', 'numpy', 'pyarrow', 'cv2', 'matplotlib', 'PIL', 'slamq._core')\n"
        "print(rc, [m for m in heavy if m in sys.modules])\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=slamq_env(), timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.splitlines()[-1] == "0 []", proc.stdout


def test_a_bad_results_file_is_still_named(tmp_path: Path) -> None:
    bad = tmp_path / "r.jsonl"
    bad.write_text('{"map": "a.pgm", "algorithm": "x", "sequence": "s", "run": "0", '
                   '"corners": "abc", "error": null}\n')
    proc = _slamq("summary", str(bad))
    assert proc.returncode == 2
    assert proc.stderr.strip() == (
        f"slamq: error: {bad}: not a slamq results file: column 'corners': invalid literal "
        "for int() with base 10: 'abc'")
    with pytest.raises(Exception, match="column 'corners'") as arrow:
        _results_table(bad)
    assert str(arrow.value) in proc.stderr


def test_jsonl_records_are_the_arrow_tables_rows(shipped: dict[str, Path],
                                                 tmp_path: Path) -> None:
    lines = shipped["jsonl"].read_text().splitlines()
    again = json.loads(lines[2])
    again["corners"] = 1  # a later record of the same key wins, where the last one is
    odd = json.loads(lines[0])
    odd.update(run=7, unknown_value=3.0, ate_rmse=2, resolution=float("nan"))  # retyped
    path = tmp_path / "r.jsonl"
    path.write_text("\n".join([*lines, json.dumps(again), json.dumps(odd)]) + "\n"
                    '{"map": "torn')
    plain = read_records(path)
    arrow = _results_table(path).to_pylist()
    assert [r["corners"] for r in plain][-2:] == [1, 67] and len(plain) == 7
    assert plain == arrow or all(
        set(a) == set(p) and all(a[k] == p[k] or (a[k] != a[k] and p[k] != p[k]) for k in a)
        for a, p in zip(arrow, plain, strict=True))
    assert plain[-1]["run"] == "7" and plain[-1]["unknown_value"] == 3
    assert isinstance(plain[-1]["ate_rmse"], float) and plain[-1]["resolution"] is None


def _numpy_summary(recs: list[dict], metric: str, ddof: int) -> dict[tuple[str, str], tuple]:
    """The old summary's numbers, with numpy: per (algorithm, sequence), of the runs
    without error, the mean and std of the metric's numbers."""
    out: dict[tuple[str, str], list[float]] = {}
    for r in recs:
        if r.get("error"):
            continue
        v = r.get(metric)
        out.setdefault((r["algorithm"], r["sequence"]), []).append(
            math.nan if v is None else float(v))
    stats = {}
    for key, values in out.items():
        a = np.asarray(values, float)
        a = a[~np.isnan(a)]
        stats[key] = (len(a), float(a.mean()) if len(a) else math.nan,
                      float(a.std(ddof=ddof)) if len(a) > ddof else math.nan)
    return stats


@pytest.mark.parametrize("ddof", [0, 1])
def test_means_and_stds_are_numpys_to_the_last_bit(ddof: int) -> None:
    """Pairwise summation as numpy does it: groups of 1 to 700 runs (numpy's blocks are 8
    and 128 values), values of very different sizes, missing values and failed runs."""
    rng = random.Random(ddof)
    recs = []
    for g, n in enumerate([1, 2, 7, 8, 9, 16, 127, 128, 129, 300, 700]):
        for i in range(n):
            big = rng.choice([1.0, 1e-9, 1e9, 1e16])
            recs.append({"algorithm": f"a{g % 3}", "sequence": f"s{g}", "run": str(i),
                         "ate_rmse": rng.uniform(0, 1) * big,
                         "corners": rng.randint(0, 10**6),
                         "occupied_fraction": None if rng.random() < 0.1 else rng.random(),
                         "error": "failed" if rng.random() < 0.05 else None})
    cols, rows = summary_rows(recs, ddof=ddof, check_settings=False)
    frame = summarize(pd.DataFrame(recs), ddof=ddof, check_settings=False)
    assert frame.columns.tolist() == cols and len(frame) == len(rows) == 11
    for metric in ("ate_rmse", "corners", "occupied_fraction"):
        expected = _numpy_summary(recs, metric, ddof)
        for row in rows:
            n, mean, std = expected[(row["algorithm"], row["sequence"])]
            got = (row[f"{metric}_n"], row[f"{metric}_mean"], row[f"{metric}_std"])
            assert got[0] == n
            for a, b in zip(got[1:], (mean, std), strict=True):
                assert a == b or (math.isnan(a) and math.isnan(b)), (metric, row, a, b)
    records_of_frame = frame.to_dict("records")
    for a, b in zip(rows, records_of_frame, strict=True):
        assert all(a[k] == b[k] or (a[k] != a[k] and b[k] != b[k]) for k in cols)


def test_the_program_freezes_what_is_left_before_exit_a_caller_in_process_not(
        shipped: dict[str, Path]) -> None:
    """``slamq`` as a program freezes the objects left for the interpreter's exit (its
    collections then skip pandas' and pyarrow's objects); ``main([...])`` called in a
    process that goes on does not."""
    code = (
        "import gc, sys\n"
        "from slamq.cli import main\n"
        f"assert main(['summary', {str(shipped['jsonl'])!r}, '-q']) == 0\n"
        "print('frozen in-process:', gc.get_freeze_count())\n"
        f"sys.argv = ['slamq', 'summary', {str(shipped['jsonl'])!r}, '-q']\n"
        "assert main() == 0\n"
        "print(gc.get_freeze_count() > 0)\n")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=slamq_env(), timeout=120)
    assert proc.returncode == 0, proc.stderr
    lines = proc.stdout.splitlines()
    assert "frozen in-process: 0" in lines and lines[-1] == "True", proc.stdout
