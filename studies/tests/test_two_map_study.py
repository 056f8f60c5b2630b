"""studies/two_map_study.py on a tiny case it must get right: two clean copies of a floor
plan (one class) and a copy with a failed loop closure (its late half doubled 0.4 m, which
the defect detector flags): the clean maps are named against the doubled one, the tie pair
abstains, and the table counts them."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
import two_map_study

from slamq.synth.damage import degrade, floor_plan
from slamq.synth.worldgen import save_world


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> tuple[Path, Path]:
    root = tmp_path_factory.mktemp("maps")
    plan = floor_plan(3, rooms=(3, 2))
    (root / "place").mkdir()
    save_world(plan, root / "place" / "clean.yaml")
    save_world(plan, root / "place" / "copy.yaml")
    save_world(degrade(plan, "doubling", 0.4, seed=1), root / "place" / "doubled.yaml")
    eye = root / "eye.csv"
    pd.DataFrame({"folder": "place", "map": ["clean.yaml", "copy.yaml", "doubled.yaml"],
                  "class": [1, 1, 2], "broken": [0, 0, 1]}).to_csv(eye, index=False)
    return root, eye


def test_two_map_study_names_the_clean_map_and_counts_the_pairs(folder, tmp_path) -> None:
    root, eye = folder
    pairs = two_map_study.pair_verdicts(root, [eye], threads=1)
    assert len(pairs) == 3 and set(pairs["maps"]) == {3}
    diff = pairs[pairs["kind"] == "different"]
    assert list(diff["outcome"]) == ["right", "right"], diff[["best", "reason", "cause"]]
    assert set(diff["best"]) == {"clean.yaml", "copy.yaml"}
    assert all("doubled_walls" in f for f in diff["flags_b"]) and not any(diff["flags_a"])
    assert not pairs["broken_named"].any()
    tie = pairs[pairs["kind"] == "tie"].iloc[0]
    assert tie["outcome"] == "abstained" and tie["cause"] == "no defect flag on either map"
    t = two_map_study.tally(pairs)
    assert (t["different"]["pairs"], t["different"]["decided"], t["different"]["right"],
            t["different"]["wrong"], t["tie"]["abstained"]) == (2, 2, 2, 0, 1)
    # the script writes its table into its section of a Markdown file
    doc = tmp_path / "doc.md"
    doc.write_text(f"x\n{two_map_study.BEGIN}\nold\n{two_map_study.END}\n")
    assert two_map_study.main(["--real", str(root), str(eye), "--threads", "1",
                               "--markdown", str(doc)]) == 0
    text = doc.read_text()
    assert "| all | 2 | 2 | 2 | 0 | 0 | 0 | 1 | 0 | 1 |" in text
    assert "no defect flag on either map: 1" in text
