"""studies/verdict_study.py: the first rule (2026-11-25), retired from the package, replays
as it was; the shipped verdict on real folders ranked by eye (studies/by_eye.csv) names no
broken map; the by-eye pair count."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
import verdict_study

import slamq
from slamq.verdict.evidence import sequence_evidence
from slamq.verdict.ranking import summarize
from slamq.verdict.rule import sequence_verdict

BY_EYE = Path(verdict_study.__file__).parent / "by_eye.csv"


def _evidence(support: dict[str, float], majority: bool = True) -> dict:
    return {"majority": majority, "notes": [], "algorithms": {
        a: {"support": s, "completeness": 1.0, "placed": True, "runs": 1, "flagged_runs": 0,
            "defects": {}} for a, s in support.items()}}


@pytest.mark.parametrize("differ", ["resolution", "orientation"])
def test_the_first_rule_ordered_confirmed_maps_of_different_grids_by_canonical_corners(
        differ: str) -> None:
    ev = _evidence({"a": 0.90, "b": 0.95, "c": 0.93})
    res = [0.05, 0.07, 0.05] if differ == "resolution" else [0.05, 0.05, 0.05]
    angle = [0.0, 0.0, 0.0] if differ == "resolution" else [0.0, 12.0, 0.0]
    df = pd.DataFrame({"sequence": "s", "algorithm": list("abc"), "corners": [10, 500, 300],
                       "corners_canonical": [10, 500, 300], "resolution": res,
                       "wall_angle": angle})
    shipped = sequence_verdict(summarize(df), "s", ev)
    assert shipped["best"] == "b" and shipped["basis"] == ["agreement"]
    first = verdict_study.first_rule(summarize(df), "s", ev)
    assert first["best"] == "a" and first["ranking"] == ["a", "c", "b"]
    assert first["basis"] == ["agreement", "corners_canonical"]


def test_the_first_rule_agrees_with_the_shipped_one_elsewhere() -> None:
    # one grid: plain corners order the confirmed maps in both rules
    df = pd.DataFrame({"sequence": "s", "algorithm": list("abcd"),
                       "corners": [10, 500, 300, 5], "corners_canonical": [1, 2, 3, 4],
                       "resolution": 0.05, "wall_angle": 0.0})
    ev = _evidence({"a": 0.90, "b": 0.95, "c": 0.93, "d": 0.5})
    for e in (ev, None, _evidence({"a": 0.9, "b": 0.9, "c": 0.9, "d": 0.9}, majority=False)):
        shipped = sequence_verdict(summarize(df), "s", e)
        first = verdict_study.first_rule(summarize(df), "s", e)
        assert {k: shipped[k] for k in first} == first
    # ground truth decides in both
    truth = df.assign(ate_rmse=[0.3, 0.1, 0.2, 0.5])
    assert verdict_study.first_rule(summarize(truth), "s", ev)["basis"] == ["ate_rmse"]


def test_by_eye_agreement_counts_pairs_of_different_classes() -> None:
    eye = pd.DataFrame({"folder": "f", "map": ["a", "b", "c"], "class": [1, 2, 2]})
    assert verdict_study.by_eye_agreement(eye, "f", ["a", "b", "c"]) == (2, 2)
    assert verdict_study.by_eye_agreement(eye, "f", ["b", "a", "c"]) == (1, 2)


@pytest.mark.parametrize("folder", ["tfm_turtlebot4/maps", "ros2_car_2"])
def test_on_real_folders_ranked_by_eye_no_broken_map_is_named(shared_data, folder) -> None:
    """studies/by_eye.csv (written before the verdict existed): in these folders the
    verdict names a map of the best class by eye, ranks the broken one after every good
    one."""
    eye = pd.read_csv(BY_EYE)
    sub = eye[eye["folder"] == folder]
    rows = []
    for r in sub.itertuples():
        path = shared_data / "maps" / folder / r.map
        q = slamq.evaluate(path)
        rows.append({"map": str(path), "sequence": folder, "algorithm": r.map, "run": 1,
                     **{k: v for k, v in q.to_dict().items() if k != "curve"}})
    ok = pd.DataFrame(rows)
    v = sequence_verdict(summarize(ok), folder, sequence_evidence(ok, folder))
    cls = dict(zip(sub["map"], sub["class"]))
    broken = set(sub.loc[sub["broken"] == 1, "map"])
    assert v["best"] is not None and cls[v["best"]] == 1, v
    assert all(v["ranking"].index(b) > v["ranking"].index(a)
               for b in broken for a in cls if cls[a] == 1), v["ranking"]
    good, total = verdict_study.by_eye_agreement(eye, folder, v["ranking"])
    assert good == total > 0


def test_with_scans_fills_only_missing_recordings(tmp_path: Path) -> None:
    (tmp_path / "sequences" / "s").mkdir(parents=True)
    (tmp_path / "sequences" / "s" / "s.rawlog").write_bytes(b"")
    df = pd.DataFrame({"sequence": ["s", "s", "t"],
                       "scans": [None, "/elsewhere/own.rawlog", None]})
    out = verdict_study.with_scans(df, tmp_path)
    assert out["scans"].tolist()[:2] == [str(tmp_path / "sequences" / "s" / "s.rawlog"),
                                         "/elsewhere/own.rawlog"]
    assert pd.isna(out["scans"].iloc[2])  # no recording of t in the folder
    assert pd.isna(df["scans"].iloc[0])   # the records themselves are not changed
