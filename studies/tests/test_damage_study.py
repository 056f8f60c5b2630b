"""studies/damage_study.py: the study covers every metric of validity.METRICS, rank
agreement with the severity comes out as made, and its command rewrites the marked section
of docs/validity.md."""

from __future__ import annotations

import damage_study
import pytest

import slamq
from slamq import synth
from slamq.results import validity

SMALL = {"rooms": (2, 2)}


@pytest.fixture(scope="module")
def plan() -> slamq.OccupancyMap:
    return synth.floor_plan(3, **SMALL)


def test_the_study_measures_every_metric_against_the_severity(plan, monkeypatch) -> None:
    # a metric added to validity.METRICS (known cells here) is studied without other change
    monkeypatch.setattr(validity, "METRICS", (*validity.METRICS, "known"))
    sev = {"drift": [0, 2, 8], "specks": [0, 0.005, 0.02]}
    scores = damage_study.records([plan, synth.floor_plan(4, **SMALL)], severities=sev)
    t = damage_study.study(scores=scores, permutations=200)
    pooled = t[t["sequence"] == "(pooled)"].set_index(["degradation", "metric"])
    assert set(pooled.index) == {(k, m) for k in sev
                                 for m in (*validity.METRICS, *damage_study.PLAN_FIGURES)}
    assert pooled.loc[("drift", "plan_f1_loss"), "spearman"] == 1.0
    assert pooled.loc[("specks", "corners"), "spearman"] == 1.0
    assert set(t["n"][t["sequence"] != "(pooled)"]) == {3}
    assert t.equals(damage_study.study(scores=scores, permutations=200))


def test_the_command_rewrites_the_marked_section(tmp_path, capsys) -> None:
    doc = tmp_path / "v.md"
    doc.write_text(f"head\n{damage_study.BEGIN}\nold\n{damage_study.END}\ntail\n")
    assert damage_study.main(["--plans", "1", "--permutations", "20", "--markdown", str(doc)]) == 0
    text = doc.read_text()
    assert text.startswith("head\n") and text.endswith("tail\n") and "old" not in text
    assert "| rotation (deg) |" in text and "python studies/damage_study.py --plans 1" in text
    (tmp_path / "bare.md").write_text("no markers\n")
    assert damage_study.main(["--plans", "1", "--permutations", "0", "--markdown",
                       str(tmp_path / "bare.md")]) == 2


def test_docs_hold_the_study_and_its_command() -> None:
    from pathlib import Path

    doc = (Path(__file__).parents[2] / "docs" / "validity.md").read_text()
    section = doc.split(damage_study.BEGIN)[1].split(damage_study.END)[0]
    assert "Regenerate with `python studies/damage_study.py" in section
    assert all(f"| {k} (" in section for k in damage_study.STUDIED)
