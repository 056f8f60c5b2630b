"""The verdict's calibrated confidence (issue 41, item 6): the counts it quotes are those of
docs/validity.md's table ("Calibrated confidence", written by studies/confidence_study.py),
and only verdicts without ground truth at a measured level carry them."""

from __future__ import annotations

import re
from pathlib import Path

import pandas as pd
import pytest

from slamq.verdict.calibration import (
    CONFIDENCE_CALIBRATION,
    calibration,
    wilson_lower,
    with_calibration,
)
from slamq.verdict.ranking import summarize
from slamq.verdict.rule import sequence_verdict

VALIDITY = Path(__file__).resolve().parents[2] / "docs" / "validity.md"
BEGIN, END = "<!-- confidence-study:begin -->", "<!-- confidence-study:end -->"


def _study_table(path: Path = VALIDITY) -> dict[str, tuple[int, int, float, float]]:
    """The "all" rows of the confidence study's table: level -> (verdicts, right, share,
    lower bound)."""
    text = path.read_text(encoding="utf-8")
    assert text.count(BEGIN) == 1 and text.count(END) == 1, "markers missing or repeated"
    section = text[text.index(BEGIN):text.index(END)]
    rows = {}
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 6 and cells[0] == "all" and cells[1] != "abstained":
            rows[cells[1]] = (int(cells[2]), int(cells[3]), float(cells[4]), float(cells[5]))
    assert rows, f"no 'all' rows between the markers of {path}"
    return rows


def test_the_constant_is_the_table_of_docs_validity() -> None:
    table = _study_table()
    assert set(table) == set(CONFIDENCE_CALIBRATION), (table, CONFIDENCE_CALIBRATION)
    for lv, (n, right, share, lower) in table.items():
        assert CONFIDENCE_CALIBRATION[lv] == (right, n), lv
        c = calibration(lv)
        assert c is not None
        assert (c["right"], c["of"]) == (right, n)
        # the share and the bound the study printed, recomputed from the counts
        assert f"{c['share']:.2f}" == f"{share:.2f}", lv
        assert f"{wilson_lower(right, n):.2f}" == f"{lower:.2f}", lv
    # the GT-free verdict never calls itself "high": that level has no record to quote
    assert "high" not in CONFIDENCE_CALIBRATION


def test_a_drifted_table_would_fail(tmp_path: Path) -> None:
    """The parser reads the numbers, not the file's shape: a changed count is seen."""
    text = VALIDITY.read_text(encoding="utf-8")
    changed = re.sub(r"\| all \| medium \| (\d+) \| (\d+) \|",
                     lambda m: f"| all | medium | {m[1]} | {int(m[2]) - 1} |", text, count=1)
    assert changed != text
    copy = tmp_path / "validity.md"
    copy.write_text(changed, encoding="utf-8")
    assert _study_table(copy)["medium"][1] != CONFIDENCE_CALIBRATION["medium"][0]


def test_only_verdicts_without_ground_truth_carry_the_record() -> None:
    df = pd.DataFrame({"sequence": "s", "algorithm": ["a", "b", "c"],
                       "corners": [300, 40, 35], "ate_rmse": [0.05, 2.0, 0.1]})
    high = sequence_verdict(summarize(df), "s")
    assert high["confidence"].startswith("high: ranked by trajectory error")
    assert high["confidence_calibration"] is None
    # corners alone (no maps at hand) was not what the study measured: no record
    low = sequence_verdict(summarize(df.drop(columns="ate_rmse")), "s")
    assert low["confidence"].startswith("low: corners") and low["confidence_calibration"] is None
    # with the maps' agreement: medium, and its record right after the level
    ev = {"majority": True, "notes": [], "algorithms": {
        a: {"support": s, "completeness": 1.0, "placed": True, "runs": 1,
            "flagged_runs": 0, "defects": {}} for a, s in zip("abc", [0.9, 0.5, 0.88])}}
    medium = sequence_verdict(summarize(df.drop(columns="ate_rmse")), "s", ev)
    right, n = CONFIDENCE_CALIBRATION["medium"]
    assert medium["confidence"].startswith(
        f"medium: right in {right} of {n} labelled verdicts ({right / n:.0%}, lower bound ")
    assert "docs/validity.md); no ground truth; the maps confirm each other" in \
        medium["confidence"]
    assert medium["confidence_calibration"] == {
        "right": right, "of": n, "share": round(right / n, 2),
        "lower_bound": round(wilson_lower(right, n), 2)}
    # abstaining says nothing of a record
    ev["majority"] = False
    none = sequence_verdict(summarize(df.drop(columns="ate_rmse")), "s", ev)
    assert none["best"] is None and none["confidence"].startswith("none: ")
    assert none["confidence_calibration"] is None


@pytest.mark.parametrize("confidence", ["high: truth", "none: why", "odd"])
def test_levels_without_a_record_are_left_as_they_are(confidence: str) -> None:
    v = with_calibration({"best": "a", "confidence": confidence})
    assert v["confidence"] == confidence and v["confidence_calibration"] is None


def test_a_verdict_of_two_maps_quotes_the_record_of_two_maps() -> None:
    """Measured apart (docs/validity.md, "Two maps counted apart"): a choice between two
    maps does not quote the record of verdicts of three and more."""
    df = pd.DataFrame({"sequence": "s", "algorithm": ["a", "b"], "corners": [300, 40]})
    ev = {"majority": False, "notes": [], "algorithms": {
        a: {"support": 0.7, "completeness": 1.0, "placed": True, "runs": 1,
            "flagged_runs": int(a == "a"),
            "defects": {f"{a}.pgm": [{"kind": "superposed"}] if a == "a" else []}}
        for a in "ab"}}
    v = sequence_verdict(summarize(df), "s", ev)
    assert v["best"] == "b" and v["confidence"].startswith("low: ")
    right, n = CONFIDENCE_CALIBRATION["low (two maps)"]
    assert (right, n) != CONFIDENCE_CALIBRATION["low"]
    assert v["confidence"].startswith(f"low: right in {right} of {n} labelled verdicts")
    assert "; two maps; a is broken on its own" in v["confidence"]
    assert v["confidence_calibration"]["of"] == n
