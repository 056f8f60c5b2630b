"""studies/benchmark_study.py: the study reads a benchmark's scored runs back, with each
generated sequence's world and noise, and writes its tables."""

from __future__ import annotations

import sys
from pathlib import Path

import benchmark_study

from slamq.runner.runner import run

# A program that "maps" perfectly: it copies the exact map (in the frame of the first pose)
# and the exact path out of the generated sequence's folder.
PERFECT = [sys.executable, "-c",
           "import shutil, sys, pathlib; seq = pathlib.Path(sys.argv[1]).parent; "
           "out = pathlib.Path(sys.argv[2]); out.mkdir(parents=True, exist_ok=True); "
           "shutil.copy(seq / 'visible_map.pgm', out / 'visible_map.pgm'); "
           "shutil.copy(seq / 'visible_map_start.yaml', out / 'map.yaml'); "
           "shutil.copy(seq / 'gt.tum', out / 'path.tum')",
           "{input}", "{out}"]

TINY = {"worlds": [{"kind": "office", "seed": 1, "size": [8, 6]}], "noise": ["none", "high"],
        "seeds": [0], "laser": {"beams": 181}, "drive": {"length": 8.0}}


def test_the_study_reads_the_scored_runs_back_and_writes_its_tables(tmp_path: Path) -> None:
    run({"base_dir": str(tmp_path), "output": "out", "report": False,
         "sequences": {"gen": {"synth": TINY}},
         "algorithms": {"perfect": {"command": PERFECT, "outputs": {
             "map": {"path": "map.yaml", "format": "yaml"},
             "trajectory": {"path": "path.tum", "format": "tum"}}}}})
    df = benchmark_study.load_benchmark(tmp_path / "out")
    assert set(df["noise"]) == {"none", "high"} and set(df["kind"]) == {"office"}
    assert set(df["world"]) == {"w01-office"}
    assert not df["broken"].any()
    tables = benchmark_study.study_benchmark(df, permutations=0)
    assert list(tables["runs"]["runs"]) == [1, 1]
    text = benchmark_study.markdown_benchmark(tables, "cmd")
    assert text.startswith("Regenerate with `cmd`.") and "| perfect | high | 1 | 1 | 0 |" in text
    doc = tmp_path / "v.md"
    doc.write_text(f"head\n{benchmark_study.BEGIN}\nold\n{benchmark_study.END}\ntail\n")
    assert benchmark_study.main([str(tmp_path / "out"), "--permutations", "0",
                                 "--markdown", str(doc)]) == 0
    assert "Regenerate with `python studies/benchmark_study.py" in doc.read_text()


def test_a_folder_without_results_is_refused(tmp_path: Path) -> None:
    import pytest

    from slamq.errors import ParamError

    with pytest.raises(ParamError, match="results.jsonl: no results"):
        benchmark_study.load_benchmark(tmp_path)
