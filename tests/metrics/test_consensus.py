"""slamq.consensus (experimental): maps scored against the consensus of the others — made-up
maps with known answers, the office world of slam_comparison_tools, and the measurement on
the three worlds that docs/validity.md reports."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from conftest import comparison_tools_runs

import slamq
from slamq.results.validity import validate


def plan() -> np.ndarray:
    img = np.full((60, 60), 254, np.uint8)
    img[5, 5:55] = 0
    img[54, 5:55] = 0
    img[5:55, 5] = 0
    img[5:55, 54] = 0
    img[5:30, 30] = 0
    return img


def test_a_map_with_a_ghost_wall_scores_worst_and_the_clean_ones_perfectly() -> None:
    good = plan()
    ghost = good.copy()
    ghost[40, 10:50] = 0
    c = slamq.consensus({"a": good, "b": good, "c": good, "ghost": ghost})
    assert [c.scores[n].f1 for n in "abc"] == [1.0, 1.0, 1.0]
    assert c.scores["ghost"].precision < 0.9 and c.scores["ghost"].recall == 1.0
    # the consensus of all four does not hold the wall only one map has
    assert np.count_nonzero(c.consensus.values[40, 10:50] == 0) == 0


def test_a_map_does_not_vote_for_itself() -> None:
    # three maps, each with its own ghost wall: with itself voting, a map's wall would
    # stand on 1 of 3 votes (not a majority either way); with 2 voters a wall needs both
    good = plan()
    maps = []
    for row in (20, 35, 45):
        m = good.copy()
        m[row, 10:50] = 0
        maps.append(m)
    c = slamq.consensus(maps)
    for name in "012":
        assert c.scores[name].precision < 0.9  # its own ghost wall is not in its consensus
        assert c.scores[name].recall == 1.0


def test_parameters_are_checked() -> None:
    with pytest.raises(slamq.ParamError, match="at least 3"):
        slamq.consensus([plan(), plan()])
    with pytest.raises(slamq.ParamError, match="quorum"):
        slamq.consensus([plan()] * 3, quorum=1.0)
    with pytest.raises(slamq.ParamError, match="base"):
        slamq.consensus([plan()] * 3, base="x")


def test_on_the_office_world_the_broken_cartographer_map_scores_worst(test_data) -> None:
    root = test_data / "slam_comparison_tools" / "test_results" / "office"
    maps = {y.name[: -len("_map.yaml")]: y for y in sorted(root.glob("*_map.yaml"))}
    c = slamq.consensus(maps)
    f1 = {n: s.f1 for n, s in c.scores.items()}
    assert min(f1, key=f1.get) == "cartographer"  # ATE 1.6 m; the others below 0.35 m
    assert f1["cartographer"] < 0.5 < min(v for n, v in f1.items() if n != "cartographer")
    assert c.base != "cartographer"


def test_measured_on_slam_comparison_tools_it_does_not_clearly_beat_corners(
        shared_data) -> None:
    """The figures of docs/validity.md: consensus F1 loss vs ATE, ground truth withheld."""
    runs = comparison_tools_runs(shared_data)
    rows = []
    for world in ("abstract", "office", "warehouse"):
        ys = {alg: y for w, alg, y, _ in runs if w == world}
        c = slamq.consensus(ys)
        for w, alg, y, ate in runs:
            if w != world:
                continue
            rows.append({"sequence": world, "algorithm": alg,
                         "corners": slamq.evaluate(y).corners,
                         "consensus_f1_loss": 1 - c.scores[alg].f1,
                         "consensus_chamfer": c.scores[alg].chamfer, "ate_rmse": ate})
    df = pd.DataFrame(rows)
    v = validate(df, permutations=1000, metrics=("corners", "consensus_f1_loss",
                                                 "consensus_chamfer"))
    pooled = v[v["sequence"] == "(pooled)"].set_index("metric")
    assert pooled.loc["corners", "concordance"] == pytest.approx(0.733, abs=0.01)
    assert pooled.loc["consensus_f1_loss", "concordance"] == pytest.approx(0.8, abs=0.01)
    assert pooled.loc["consensus_f1_loss", "spearman"] == pytest.approx(
        pooled.loc["corners", "spearman"])  # the same Spearman: 0.67 both
    assert pooled.loc["consensus_chamfer", "concordance"] == pytest.approx(0.6, abs=0.01)
    # in abstract, 3 of 5 maps are broken: the consensus names a broken map best
    abstract = df[df["sequence"] == "abstract"].set_index("algorithm")
    assert abstract["consensus_f1_loss"].idxmin() == "lidar_rtabmap"
    assert abstract.loc["lidar_rtabmap", "ate_rmse"] > 1.0
