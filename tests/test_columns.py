"""The column table (slamq.columns): it agrees with the models it describes, every output
takes its columns from it, and adding a map column is one row plus its computation."""

from __future__ import annotations

import json
from collections.abc import Iterator
from dataclasses import fields
from pathlib import Path

import cv2
import numpy as np
import pytest

import slamq
from slamq.columns import (
    COLUMNS,
    PLACES,
    Column,
    group_names,
    record_columns,
    register_column,
    shown,
    unregister_column,
)
from slamq.models import MapQuality
from slamq.models.comparison import COMPARISON_FIGURES, MapComparison


def test_the_map_columns_are_the_fields_of_map_quality_in_order() -> None:
    assert group_names("map") == tuple(
        f.name for f in fields(MapQuality) if f.name not in ("params", "extra"))
    assert group_names("param") == tuple(f"param_{f.name}" for f in fields(slamq.Params))
    assert {f"gt_{f}" for f in COMPARISON_FIGURES} <= set(group_names("gt"))
    assert set(COMPARISON_FIGURES) <= {f.name for f in fields(MapComparison)}
    # a map result's keys are the record's map and parameter columns, in the table's order
    q = slamq.evaluate(np.full((4, 4), 254, np.uint8), curve=True)
    assert tuple(q.to_dict()) == group_names("map", "param")
    assert record_columns(curve=True) == group_names("run", "map", "param", "ate", "gt", "rel")


def test_every_place_names_a_direction_or_a_unit_where_it_needs_one() -> None:
    for c in COLUMNS.values():
        assert c.dtype in ("str", "int", "float", "ints"), c
        if c.dtype in ("str", "ints"):
            assert not set(c.at) & {"summary", "console", "ranked", "validity", "truth",
                                    "timeline"}, c.name
    # what is ranked or judges the others says which way is better and why
    for c in (*shown("ranked"), *shown("truth"), COLUMNS["corners_canonical"]):
        assert c.better in ("lower", "higher") and c.why, c.name
    # validate() takes its metrics as lower-is-better
    assert all(c.better == "lower" for c in shown("validity"))
    # positions are distinct within a place and a group
    for place in PLACES:
        seen = [(c.group, c.at[place]) for c in shown(place)]
        assert len(seen) == len(set(seen)), place


def test_the_outputs_keep_their_columns() -> None:
    """The lists the outputs had by hand before the table, as the table gives them."""
    from slamq.results import summary, validity
    from slamq.verdict.ranking import METRICS

    assert [(m.key, m.heading, m.higher, m.log) for m in METRICS] == [
        ("ate_rmse", "ATE RMSE (m)", False, True),
        ("occupied_fraction", "occupied fraction", False, False),
        ("corners", "corners", False, True),
        ("enclosed_areas", "enclosed areas", False, True),
        ("gt_f1", "GT F1", True, False),
        ("gt_chamfer", "GT chamfer (m)", False, True),
        ("rel_trans_abs_mean", "relations trans. error (m)", False, True),
    ]
    assert tuple(summary.SUMMARY_METRICS) == (
        "occupied_fraction", "proportion", "threshold", "corners", "corners_canonical",
        "enclosed_areas", "enclosed_unknown_value", "occupied", "free", "unknown", "known",
        "total", "known_area_m2", "known_box_m2", "resolution", "wall_angle")
    assert tuple(summary.ATE_METRICS) == (
        "ate_rmse", "ate_mean", "ate_median", "ate_std", "ate_min", "ate_max", "ate_n")
    assert tuple(summary.GT_METRICS) == (
        "gt_precision", "gt_recall", "gt_f1", "gt_iou", "gt_ne", "gt_reverse", "gt_chamfer",
        "gt_coverage")
    assert tuple(summary.REL_METRICS) == (
        "rel_trans_abs_mean", "rel_trans_abs_std", "rel_trans_sq_mean", "rel_trans_sq_std",
        "rel_trans_max", "rel_rot_abs_mean", "rel_rot_abs_std", "rel_rot_sq_mean",
        "rel_rot_sq_std", "rel_rot_max", "rel_n", "rel_n_unplaced")
    assert tuple(validity.METRICS) == ("corners", "corners_canonical", "occupied_fraction",
                                       "proportion", "enclosed_areas")
    assert dict(validity.TRUTHS) == {"ate_rmse": False, "gt_chamfer": False, "gt_f1": True,
                                     "rel_trans_abs_mean": False, "rel_rot_abs_mean": False}
    assert [(c.short, c.format) for c in shown("eval")] == [
        ("known", ".1f"), ("occupied", ".1f"), ("occupied_fraction", ".4f"),
        ("proportion", ".4f"), ("corners", ".1f"), ("canonical", ".1f"),
        ("enclosed_areas", ".1f"), ("peak_at_u", ".1f")]


def test_a_table_row_must_be_well_formed() -> None:
    with pytest.raises(slamq.ParamError, match="dtype"):
        Column("x", "complex", "map")
    with pytest.raises(slamq.ParamError, match="place"):
        Column("x", "int", "map", at={"sumary": 1})
    with pytest.raises(slamq.ParamError, match="only a map column"):
        Column("x", "int", "ate", compute=len)
    with pytest.raises(slamq.ParamError, match="already"):
        register_column(Column("corners", "int", "map"))
    with pytest.raises(slamq.ParamError, match="slamq's own"):
        unregister_column("corners")
    with pytest.raises(TypeError):
        COLUMNS["x"] = Column("x", "int", "map")  # type: ignore[index]


# ------------------------------------------------------------------ adding a column


def _black(grid: slamq.OccupancyMap) -> int:
    """The new column's computation: known cells that are pure black."""
    return int(np.count_nonzero((grid.values == 0) & ~grid.unknown))


@pytest.fixture()
def black_cells() -> Iterator[Column]:
    """One row: a map column with its computation, summarised, ranked, on detail pages."""
    col = register_column(Column(
        "black_cells", "int", "map", label="black cells", unit="cells", better="lower",
        why="a test column: fewer black cells", compute=_black,
        at={"summary": 99, "ranked": 99, "detail": 99, "eval": 99}))
    try:
        yield col
    finally:
        unregister_column("black_cells")
    assert "black_cells" not in COLUMNS and "black_cells" not in record_columns()


def _room(n: int, walls: int) -> np.ndarray:
    img = np.full((n, n), 205, np.uint8)
    img[4:-4, 4:-4] = 254
    img[4, 4:-4] = img[-5, 4:-4] = 0
    img[4:-4, 4] = img[4:-4, -5] = 0
    img[10, 8:8 + walls] = 0
    return img


def _write_map(path: Path, img: np.ndarray) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    assert cv2.imwrite(str(path.with_suffix(".pgm")), img)
    path.with_suffix(".yaml").write_text(
        f"image: {path.name}.pgm\nresolution: 0.05\norigin: [0, 0, 0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    return path.with_suffix(".yaml")


@pytest.mark.parametrize("suffix", [".parquet", ".jsonl"])
def test_a_new_map_column_is_one_row_plus_its_computation(
        black_cells: Column, tmp_path: Path, suffix: str) -> None:
    from slamq.report import build_report
    from slamq.results.formats import read_results, write_csv, write_json
    from slamq.results.table import format_table

    img = _room(30, 3)
    expected = int(np.count_nonzero(img == 0))
    # the computation runs with every evaluation, by the core and by the reference alike
    q = slamq.evaluate(img, verify=True)
    assert q.extra == {"black_cells": expected} and q.value("black_cells") == expected
    assert list(q.to_dict())[-len(fields(slamq.Params)) - 1] == "black_cells"
    assert "black_cells" in format_table([q]).splitlines()[0].split()

    # results files: slamq eval's and a batch's, read back with the column's type
    write_json(tmp_path / "r.json", [q])
    write_csv(tmp_path / "r.csv", [q])
    for name in ("r.json", "r.csv"):
        assert slamq.read_results(tmp_path / name)["black_cells"].tolist() == [expected]
    root = tmp_path / "runs"
    for alg, walls in (("a", 2), ("b", 6)):
        for run in ("1", "2"):
            _write_map(root / alg / "office" / run / "map", _room(30, walls + int(run)))
    out = tmp_path / f"results{suffix}"
    records = list(slamq.evaluate_many(root, out=out, threads=1))
    assert all(r["error"] is None for r in records) and len(records) == 4
    keys = list(records[0])  # the map columns' last, before the parameters
    assert keys.index("black_cells") == keys.index("param_log_threshold") - 1
    frame = read_results(out)
    assert str(frame["black_cells"].dtype) == "int64"
    if suffix == ".parquet":
        import pyarrow.parquet as pq

        assert str(pq.read_schema(out).field("black_cells").type) == "int64"
    else:
        first = json.loads(out.read_text().splitlines()[0])
        assert isinstance(first["black_cells"], int)
    walls = {("a", "1"): 3, ("a", "2"): 4, ("b", "1"): 7, ("b", "2"): 8}
    got = {(r.algorithm, r.run): int(r.black_cells) for r in frame.itertuples()}
    base = 2 * 22 + 2 * 20  # the room's four walls
    assert got == {k: base + v for k, v in walls.items()}

    # the summary: its mean, std and count
    s = slamq.summarize(frame).set_index("algorithm")
    assert s.loc["a", "black_cells_mean"] == base + 3.5
    assert s.loc["b", "black_cells_n"] == 2

    # the report: a ranked column of the sequence's table, the Markdown table, detail pages
    if suffix == ".jsonl":
        return  # (the report reads either file alike)
    index = build_report(out, tmp_path / "report", gifs=False, trajectories=False)
    page = index.read_text(encoding="utf-8")
    assert 'data-metric="black_cells"' in page and "black cells (cells)" in page
    assert "lower is better &mdash; a test column" in page
    assert "black cells (cells)" in (tmp_path / "report" / "tables.md").read_text()
    details = list((tmp_path / "report").rglob("*.html"))
    assert any('<th title="black_cells">black cells</th>' in p.read_text(encoding="utf-8")
               for p in details)
