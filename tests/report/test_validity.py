"""Measured validity (slamq.results.validity, slamq validate): hand-made rankings with known
answers, the CLI, and the figures on slam_comparison_tools."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest
from conftest import comparison_tools_runs, slamq_env

import slamq
from slamq.results.validity import validate


def records(metric: list, truth: list, truth_col: str = "ate_rmse", seq: str = "s"
            ) -> pd.DataFrame:
    return pd.DataFrame({"sequence": seq, "algorithm": [f"a{i}" for i in range(len(metric))],
                         "corners": metric, truth_col: truth, "error": None})


def test_the_same_order_agrees_fully_and_the_reverse_order_not_at_all() -> None:
    same = validate(records([1, 2, 3, 4, 5], [0.1, 0.2, 0.3, 0.4, 0.5]), permutations=0)
    row = same[same["sequence"] == "s"].iloc[0]
    assert row["spearman"] == 1.0 and row["concordance"] == 1.0 and row["pairs"] == 10
    rev = validate(records([5, 4, 3, 2, 1], [0.1, 0.2, 0.3, 0.4, 0.5]), permutations=0)
    assert rev.iloc[0]["spearman"] == -1.0 and rev.iloc[0]["concordance"] == 0.0


def test_a_higher_is_better_truth_is_flipped() -> None:
    # F1 is higher-is-better: the map with the fewest corners has the highest F1 -> agree
    v = validate(records([1, 2, 3, 4], [0.99, 0.9, 0.5, 0.1], "gt_f1"), permutations=0)
    assert v.iloc[0]["spearman"] == 1.0


def test_pooling_weights_sequences_and_reference_and_failed_rows_are_left_out() -> None:
    df = pd.concat([records([1, 2, 3], [1, 2, 3], seq="x"),
                    records([1, 2, 3, 4, 5, 6], [6, 5, 4, 3, 2, 1], seq="y"),
                    pd.DataFrame({"sequence": ["x", "x"], "algorithm": ["ground_truth", "b"],
                                  "corners": [0, 99], "ate_rmse": [0.0, 0.0],
                                  "error": [None, "b.yaml: broken"]})])
    v = validate(df, permutations=0).set_index("sequence")
    assert v.loc["x", "n"] == 3 and v.loc["y", "n"] == 6
    assert v.loc["(pooled)", "spearman"] == pytest.approx((3 * 1 - 6 * 1) / 9)
    assert v.loc["(pooled)", "pairs"] == 3 + 15


def test_the_permutation_p_value_separates_signal_from_noise() -> None:
    rng = np.random.default_rng(1)
    truth = np.arange(12, dtype=float)
    strong = validate(records(list(truth), list(truth)), permutations=500)
    noise = validate(records(list(rng.permutation(truth)), list(truth)), permutations=500)
    assert strong.iloc[0]["p_value"] < 0.01
    assert noise.iloc[0]["p_value"] > 0.05
    shuffled = records(list(rng.permutation(truth)), list(truth))
    assert validate(shuffled, permutations=200, seed=3).equals(
        validate(shuffled, permutations=200, seed=3))  # reproducible by seed


def test_cli_prints_the_pooled_table_and_writes_every_row(tmp_path) -> None:
    res = tmp_path / "r.csv"
    records([1, 2, 3, 4], [0.1, 0.3, 0.2, 0.9]).to_csv(res, index=False)
    out = tmp_path / "v.json"
    proc = subprocess.run([sys.executable, "-m", "slamq", "validate", str(res), "--json",
                           str(out), "--permutations", "100"], capture_output=True,
                          text=True, env=slamq_env(), timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert "(pooled)" in proc.stdout and "+0.80" in proc.stdout
    rows = json.loads(out.read_text())
    assert {r["sequence"] for r in rows} == {"s", "(pooled)"}
    empty = tmp_path / "e.csv"
    pd.DataFrame({"sequence": ["s"], "algorithm": ["a"], "corners": [1]}).to_csv(empty)
    proc = subprocess.run([sys.executable, "-m", "slamq", "validate", str(empty)],
                          capture_output=True, text=True, env=slamq_env(), timeout=60)
    assert proc.returncode == 2 and "no sequence with ground truth" in proc.stderr


def test_on_slam_comparison_tools_corners_agree_and_enclosed_areas_are_inverted(
        shared_data) -> None:
    """The issue's measurement, reproduced: pooled concordance with ATE, 3 worlds x 5."""
    rows = []
    for world, alg, y, ate in comparison_tools_runs(shared_data):
        d = slamq.evaluate(y, canonical_resolution=0.07).to_dict()
        d.update(sequence=world, algorithm=alg, error=None, ate_rmse=ate)
        rows.append(d)
    v = validate(pd.DataFrame(rows), permutations=1000)
    pooled = v[v["sequence"] == "(pooled)"].set_index("metric")
    assert pooled.loc["corners", "concordance"] == pytest.approx(0.733, abs=0.01)
    assert pooled.loc["corners", "p_value"] < 0.05
    assert pooled.loc["occupied_fraction", "concordance"] == pytest.approx(0.5, abs=0.01)
    assert pooled.loc["proportion", "concordance"] == pytest.approx(0.5, abs=0.01)
    assert pooled.loc["enclosed_areas", "concordance"] == pytest.approx(0.267, abs=0.01)
    # the canonical count (issue 13 item 2) keeps the signal of corners
    assert pooled.loc["corners_canonical", "concordance"] == pytest.approx(0.733, abs=0.01)
    assert pooled.loc["corners_canonical", "p_value"] < 0.05


def test_the_shipped_figures_are_those_of_the_docs() -> None:
    """SHIPPED_CONCORDANCE (printed by every report) is docs/validity.md's synthetic table
    and the README's slam_comparison_tools column."""
    import re
    from pathlib import Path

    from slamq.results.validity import SHIPPED_CONCORDANCE

    root = Path(__file__).resolve().parents[2]
    doc = (root / "docs" / "validity.md").read_text(encoding="utf-8")
    readme = (root / "README.md").read_text(encoding="utf-8")
    header = next(line for line in doc.splitlines() if line.startswith("| degradation ("))
    names = [c.strip() for c in header.strip("|").split("|")]
    for k, kind in enumerate(("drift", "doubling", "rotation", "specks"), start=1):
        row = next(line for line in doc.splitlines() if line.startswith(f"| {kind} ("))
        cells = [c.strip() for c in row.strip("|").split("|")]
        for metric, values in SHIPPED_CONCORDANCE.items():
            concordance = float(cells[names.index(metric)].split("/")[1])
            assert concordance == values[k], (kind, metric)
    for metric, values in SHIPPED_CONCORDANCE.items():
        label = metric.replace("_", " ") if metric != "corners_canonical" else metric
        row = next(line for line in readme.splitlines() if line.startswith(f"| {label} |"))
        assert re.search(rf"\| {values[0]:.2f}", row), (metric, row)


def _loop_p_value(groups: list[tuple[np.ndarray, np.ndarray]], seed: int,
                  permutations: int) -> float:
    """The permutation p-value drawn one shuffle at a time, as validity.py did before it
    drew them all at once: shuffle k of every group in turn."""
    from slamq.results.validity import _centred_ranks, _pooled_centred

    rng = np.random.default_rng(seed)
    centred = [(_centred_ranks(a), _centred_ranks(b)) for a, b in groups]
    observed = abs(_pooled_centred(centred))
    hits = 0
    for _ in range(permutations):
        shuffled = [(ra, rb[rng.permutation(len(rb))]) for ra, rb in centred]
        hits += abs(_pooled_centred(shuffled)) >= observed - 1e-12
    return (1 + hits) / (1 + permutations)


@pytest.mark.parametrize("sizes", [[5], [7, 7, 7], [6, 9], [4, 4, 11]])
def test_shuffles_drawn_at_once_are_the_shuffles_drawn_one_by_one(sizes: list[int]) -> None:
    from slamq.results.validity import _p_value

    rng = np.random.default_rng(11)
    groups = [(rng.normal(size=n), rng.normal(size=n)) for n in sizes]
    groups[0] = (groups[0][0], groups[0][0] + 0.3 * rng.normal(size=sizes[0]))  # a signal
    mine = np.random.default_rng(3)
    got = _p_value(groups, mine, 300)
    assert got == _loop_p_value(groups, 3, 300)
    # and the generator is left where the one-by-one draws leave it
    theirs = np.random.default_rng(3)
    for _ in range(300):
        for n in sizes:
            theirs.permutation(n)
    assert mine.integers(1 << 62) == theirs.integers(1 << 62)
