"""The report's verdict (slamq.verdict.rule): ground truth first, corners alone without it,
partial and reference maps never named best; and the issue's test on real data."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from conftest import comparison_tools_runs

import slamq
from slamq.verdict.evidence import sequence_evidence
from slamq.verdict.ranking import summarize
from slamq.verdict.rule import sequence_verdict, verdict_sentence


def verdict(**columns) -> dict:
    df = pd.DataFrame({"sequence": "s", **columns})
    return sequence_verdict(summarize(df), "s")


def test_trajectory_error_decides_over_the_map_metrics() -> None:
    v = verdict(algorithm=["a", "b", "c"], corners=[900, 10, 50],
                occupied_fraction=[0.9, 0.01, 0.1], ate_rmse=[0.03, 4.0, 0.5])
    assert v["best"] == "a" and v["ranking"] == ["a", "c", "b"] and v["basis"] == ["ate_rmse"]
    assert v["confidence"].startswith("high")


def test_the_ground_truth_map_decides_without_trajectories() -> None:
    v = verdict(algorithm=["a", "b", "c"], corners=[10, 300, 40],
                gt_f1=[0.2, 0.99, 0.99], gt_chamfer=[1.0, 0.05, 0.02])
    # b and c tie on F1: the smaller chamfer distance goes first
    assert v["ranking"] == ["c", "b", "a"] and v["basis"] == ["gt_f1", "gt_chamfer"]


def test_without_ground_truth_corners_alone_and_a_partial_map_is_never_best() -> None:
    v = verdict(algorithm=["half", "good", "noisy", "ground_truth"],
                corners=[5, 100, 400, 60], enclosed_areas=[0, 90, 1, 0],
                occupied_fraction=[0.01, 0.2, 0.05, 0.1], known=[400, 1000, 990, 1000])
    assert v["best"] == "good" and v["ranking"] == ["good", "noisy", "half"]
    assert v["basis"] == ["corners"] and v["confidence"].startswith("low")
    assert any("half's map knows 40%" in w for w in v["warnings"])
    assert "ground_truth" not in v["ranking"]  # a reference map is never ranked


def test_close_corner_counts_are_no_clear_winner() -> None:
    v = verdict(algorithm=["a", "b"], corners=[100, 110])
    assert "no clear winner: a and b are within 25%" in v["confidence"]
    assert verdict_sentence(v).startswith("s: a is best by corners (of 2; confidence low")


def test_an_algorithm_without_the_basis_is_not_ranked() -> None:
    v = verdict(algorithm=["a", "b", "c"], corners=[1, 2, 3], ate_rmse=[0.5, 0.1, math.nan])
    assert v["ranking"] == ["b", "a"] and "not ranked, no ate_rmse: c" in v["warnings"]


def test_nothing_to_rank() -> None:
    v = verdict(algorithm=["ground_truth"], corners=[3])
    assert v["best"] is None and v["ranking"] == []
    assert verdict_sentence(v).startswith("s: no algorithm is named best")


def test_on_slam_comparison_tools_the_verdict_never_names_a_broken_map(shared_data) -> None:
    """The issue's test: with trajectories and ground-truth maps the verdict names an
    algorithm in the ATE top two of each world; with maps only, never a map whose ATE is
    more than 10 times the best."""
    maps = shared_data / "maps" / "slam_comparison_tools"
    rows = []
    for world, alg, y, ate in comparison_tools_runs(shared_data):
        gt_map = maps / "ground_truths" / f"{world}_ground_truth.yaml"
        q = slamq.evaluate(y, canonical_resolution=0.07)
        c = slamq.compare(y, gt_map)
        rows.append({"sequence": world, "algorithm": alg, "map": str(y), "run": 1,
                     "corners": q.corners,
                     "corners_canonical": q.corners_canonical,
                     "wall_angle": q.wall_angle,
                     "occupied_fraction": q.occupied_fraction,
                     "enclosed_areas": q.enclosed_areas, "known": q.known,
                     "ate_rmse": ate, "gt_f1": c.f1, "gt_chamfer": c.chamfer})
    df = pd.DataFrame(rows)
    for world, part in df.groupby("sequence"):
        ate = part.set_index("algorithm")["ate_rmse"]
        top2 = set(ate.nsmallest(2).index)
        full = sequence_verdict(summarize(part), world)
        assert full["best"] in top2, (world, full)
        gt_only = sequence_verdict(summarize(part.drop(columns="ate_rmse")), world)
        assert gt_only["best"] in top2, (world, gt_only)
        maps_only = sequence_verdict(
            summarize(part.drop(columns=["ate_rmse", "gt_f1", "gt_chamfer"])), world)
        assert maps_only["best"] is not None
        assert ate[maps_only["best"]] <= 10 * ate.min(), (world, maps_only, ate.to_dict())
        assert "cartographer" not in (full["best"], gt_only["best"], maps_only["best"])
        # the broken maps are turned (cartographer 2-8 degrees): with the wall angles known
        # the maps-only verdict ranks by corners_canonical, and still names a good map
        assert maps_only["basis"] == ["corners_canonical"], maps_only
        assert "differ in orientation" in " ".join(maps_only["warnings"])
        plain = sequence_verdict(summarize(part.drop(columns=[
            "ate_rmse", "gt_f1", "gt_chamfer", "wall_angle"])), world)
        assert plain["basis"] == ["corners"]
        # the defaults have no corners_canonical: then the turned maps are not ranked by
        # corners at all (no best), and the warning says how to get the canonical count
        default = sequence_verdict(summarize(part.drop(columns=[
            "ate_rmse", "gt_f1", "gt_chamfer", "corners_canonical"])), world)
        assert default["best"] is None and default["basis"] == ["corners"], default
        assert "canonical_resolution=0.07" in " ".join(default["warnings"])
        # with the maps' agreement and defect flags (the report's verdict without ground
        # truth): slam_toolbox (ATE second of five) where most maps agree; in abstract,
        # where three of five maps are broken, no majority agrees but gmapping and
        # slam_toolbox do (consistency 1.00): named from that group, confidence low
        hidden = part.drop(columns=["ate_rmse", "gt_f1", "gt_chamfer"])
        agreed = sequence_verdict(summarize(hidden), world, sequence_evidence(hidden, world))
        assert agreed["basis"][0] == "agreement" and "cartographer" != agreed["best"]
        assert agreed["ranking"][-1] == "cartographer", agreed
        assert agreed["best"] in top2, (world, agreed, ate.to_dict())
        if world == "abstract":
            assert agreed["confidence"].startswith("low:"), agreed
            assert "gmapping, slam_toolbox agree with each other" in agreed["confidence"]
        else:
            assert agreed["best"] == "slam_toolbox", agreed


@pytest.mark.parametrize("key", ["proportion", "occupied_fraction", "enclosed_areas"])
def test_the_metrics_without_measured_validity_never_decide(key: str) -> None:
    v = verdict(algorithm=["a", "b"], corners=[10, 500], **{key: [100.0, 0.0]})
    assert v["best"] == "a" and v["basis"] == ["corners"]


def test_completeness_is_judged_by_area_and_corners_need_one_resolution() -> None:
    # b knows 300 cells of 0.1 m (3 m^2), a 1000 cells of 0.05 m (2.5 m^2): neither is
    # partial by area, though b has 30% of a's cells
    v = verdict(algorithm=["a", "b"], corners=[10, 20], known=[1000, 300],
                resolution=[0.05, 0.1], known_area_m2=[2.5, 3.0])
    assert not any("partial" in w for w in v["warnings"])
    # ... but corners counted at two resolutions are not comparable: nobody is named
    assert v["best"] is None and v["confidence"].startswith("none")
    assert "differ in resolution" in " ".join(v["warnings"])


def test_known_area_is_in_every_result() -> None:
    m = slamq.OccupancyMap(np.full((10, 20), 254, np.uint8), np.zeros((10, 20), bool),
                           resolution=0.05)
    q = slamq.evaluate(m)
    assert q.resolution == 0.05 and q.known_area_m2 == pytest.approx(200 * 0.0025)
    assert math.isnan(slamq.evaluate(np.full((3, 3), 254, np.uint8)).known_area_m2)


def test_eval_and_summarize_warn_when_maps_differ_in_resolution(tmp_path) -> None:
    import subprocess
    import sys

    from conftest import slamq_env

    img = np.full((20, 20), 254, np.uint8)
    img[5:15, 5:15] = 0
    for name, res in (("fine", 0.05), ("coarse", 0.1)):
        (tmp_path / f"{name}.pgm").write_bytes(b"P5 20 20 255\n" + img.tobytes())
        (tmp_path / f"{name}.yaml").write_text(f"image: {name}.pgm\nresolution: {res}\n"
                                               "origin: [0, 0, 0]\n")
    proc = subprocess.run([sys.executable, "-m", "slamq", "eval", str(tmp_path / "fine.yaml"),
                           str(tmp_path / "coarse.yaml")], capture_output=True, text=True,
                          env=slamq_env(), timeout=60)
    assert proc.returncode == 0, proc.stderr
    assert ("slamq: warning: the maps have different resolutions (0.05 m: fine.yaml; 0.1 m: "
            "coarse.yaml): their corners, enclosed areas and cell counts are not comparable"
            ) in proc.stderr  # issue 42, point 5: the warning names the maps
    df = pd.DataFrame([slamq.evaluate(tmp_path / f"{n}.yaml").to_dict() | {"sequence": "s",
                       "algorithm": n} for n in ("fine", "coarse")])
    with pytest.warns(UserWarning, match="s: the maps have different resolutions"):
        slamq.summarize(df)


def test_turned_maps_are_ranked_by_canonical_corners_or_not_at_all() -> None:
    v = verdict(algorithm=["a", "b", "c"], corners=[100, 30, 200],
                corners_canonical=[90, 150, 160], wall_angle=[0.1, 6.0, 0.3])
    assert v["basis"] == ["corners_canonical"] and v["best"] == "a"
    assert any("differ in orientation" in w for w in v["warnings"])
    # without the canonical count (an older results file) nobody is named
    old = verdict(algorithm=["a", "b"], corners=[100, 30], wall_angle=[0.1, 6.0])
    assert old["best"] is None and old["basis"] == ["corners"]
    # within a degree modulo 90 the maps are comparable: plain corners decide
    same = verdict(algorithm=["a", "b"], corners=[100, 30], corners_canonical=[10, 90],
                   wall_angle=[44.8, -44.9])
    assert same["basis"] == ["corners"] and same["best"] == "b"


def _evidence(support: dict, *, completeness: dict | None = None, defects: tuple = (),
              unplaced: tuple = (), majority: bool = True, kind: str = "superposed",
              kinds: dict | None = None) -> dict:
    kinds = {a: kind for a in defects} | (kinds or {})
    return {"majority": majority, "notes": [], "maps": len(support), "algorithms": {
        a: {"support": s, "completeness": (completeness or {}).get(a, 1.0),
            "placed": a not in unplaced, "runs": 1, "flagged_runs": int(a in kinds),
            "defects": {f"{a}.pgm": [{"kind": kinds[a], "score": 1.0,
                                      "bbox": [0, 0, 1, 1], "note": ""}]
                        if a in kinds else []}}
        for a, s in support.items()}}


def agreement_verdict(evidence: dict, **columns) -> dict:
    df = pd.DataFrame({"sequence": "s", **columns})
    return sequence_verdict(summarize(df), "s", evidence)


def test_without_ground_truth_agreement_flags_and_corners_only_order_confirmed_maps() -> None:
    ev = _evidence({"a": 0.90, "b": 0.88, "c": 0.50, "d": 0.89}, defects=("d",))
    v = agreement_verdict(ev, algorithm=list("abcd"), corners=[300, 200, 10, 5])
    # c has the fewest corners but the others do not confirm it; d is flagged on its own
    assert v["best"] == "b" and v["ranking"][:2] == ["b", "a"]
    assert set(v["ranking"][2:]) == {"c", "d"}
    assert v["basis"] == ["agreement", "corners"]
    assert any("c is never named best: its walls disagree" in w for w in v["warnings"])
    assert any("d is never named best: defects: superposed" in w for w in v["warnings"])
    assert verdict_sentence(v).startswith("s: b is best by agreement with the other maps")


@pytest.mark.parametrize("differ", ["resolution", "orientation"])
def test_corners_never_order_confirmed_maps_of_different_grids(differ: str) -> None:
    # issue 25: corners only break ties between maps of one resolution and frame; the
    # canonical count is not used either: the confirmed maps are ordered by support
    ev = _evidence({"a": 0.90, "b": 0.95, "c": 0.93})
    res = [0.05, 0.07, 0.05] if differ == "resolution" else [0.05, 0.05, 0.05]
    angle = [0.0, 0.0, 0.0] if differ == "resolution" else [0.0, 12.0, 0.0]
    v = agreement_verdict(ev, algorithm=list("abc"), corners=[10, 500, 300],
                          corners_canonical=[10, 500, 300], resolution=res, wall_angle=angle)
    assert v["best"] == "b" and v["ranking"] == ["b", "c", "a"], v
    assert v["basis"] == ["agreement"]
    assert "corners cannot compare them: their support orders them" in v["confidence"]
    # the same maps on one grid: plain corners order them
    same = agreement_verdict(ev, algorithm=list("abc"), corners=[10, 500, 300],
                             resolution=[0.05] * 3, wall_angle=[0.0] * 3)
    assert same["best"] == "a" and same["basis"] == ["agreement", "corners"]


def test_without_ground_truth_a_partial_or_unplaced_map_is_never_best() -> None:
    ev = _evidence({"a": 0.9, "b": 0.9, "c": 0.9, "e": 0.9},
                   completeness={"a": 0.5, "b": 0.95, "c": 0.9, "e": 0.9}, unplaced=("e",))
    v = agreement_verdict(ev, algorithm=list("abce"), corners=[1, 50, 60, 0])
    assert v["best"] == "b"
    assert any("a's map knows 53% of the area the other maps agree exists" in w
               for w in v["warnings"])
    assert any("e is never named best: could not be registered" in w for w in v["warnings"])


@pytest.mark.parametrize("case", ["two maps", "no majority", "all flagged"])
def test_without_ground_truth_the_verdict_abstains_and_says_why(case: str) -> None:
    if case == "two maps":
        ev, algs, why = _evidence({"a": 0.9, "b": 0.9}), ["a", "b"], "fewer than three maps"
    elif case == "no majority":
        ev = _evidence({"a": 0.4, "b": 0.5, "c": 0.45}, majority=False)
        algs, why = ["a", "b", "c"], "disagree among themselves"
    else:
        ev = _evidence({"a": 0.9, "b": 0.9, "c": 0.9}, defects=("a", "b", "c"))
        algs, why = ["a", "b", "c"], "every map is flagged or partial"
    v = agreement_verdict(ev, algorithm=algs, corners=list(range(10, 10 + len(algs))))
    assert v["best"] is None and why in v["confidence"]
    # the sentence gives the reason, not the first note
    sentence = verdict_sentence(v)
    assert sentence.startswith("s: no algorithm is named best (") and why in sentence


def test_of_two_maps_one_flagged_on_its_own_the_other_is_named() -> None:
    ev = _evidence({"a": 0.7, "b": 0.7}, defects=("a",), kind="doubled_walls")
    v = agreement_verdict(ev, algorithm=["a", "b"], corners=[5, 50])
    assert v["best"] == "b"
    # two maps are weaker evidence than a majority: low, saying which map is flagged
    assert v["confidence"].startswith("low: ")
    assert "two maps; a is wrong on its own (defects: doubled_walls)" in v["confidence"]
    assert v["ranking"] == ["b", "a"]
    # a flag that sound maps can carry decides only two placed maps, the other not partial
    for ev, held in ((_evidence({"a": 0.2, "b": 0.2}, defects=("a",), kind="doubled_walls",
                                unplaced=("a", "b")), "the two are not placed"),
                     (_evidence({"a": 0.7, "b": 0.7}, defects=("a",), kind="doubled_walls",
                                completeness={"b": 0.5}), "b is partial")):
        v = agreement_verdict(ev, algorithm=["a", "b"], corners=[5, 50])
        # the reason says what held the flag back, and what would tell the maps apart
        assert v["best"] is None and "a carries doubled_walls, which decides" in \
            v["confidence"] and v["confidence"].endswith(
                f"and {held}; each map's own scans (its recording and trajectory) could tell "
                "them apart"), v["confidence"]
    plain = agreement_verdict(_evidence({"a": 0.7, "b": 0.7}), algorithm=["a", "b"],
                              corners=[5, 50])
    assert "right; neither carries a defect flag; each map's own scans" in plain["confidence"]


def test_doubled_walls_alone_decide_two_maps_only_with_scans_under_d1(monkeypatch) -> None:
    """Candidate D1 of docs/validity.md ("Doubled walls alone do not decide two maps"; not
    adopted, ``rule.MILD_DEFECTS_DECIDE`` True): with it, a flag found on sound maps too
    names the other of two only when the other's own scans confirm it."""
    from slamq.verdict import rule

    assert rule.MILD_DEFECTS_DECIDE is True
    monkeypatch.setattr(rule, "MILD_DEFECTS_DECIDE", False)
    ev = _evidence({"a": 0.7, "b": 0.7}, defects=("a",), kind="doubled_walls")
    v = agreement_verdict(ev, algorithm=["a", "b"], corners=[5, 50])
    assert v["best"] is None
    assert ("a carries doubled_walls, which is found on sound maps too: it names b of two "
            "only when b's own scans confirm it") in v["confidence"], v["confidence"]
    # with their scans: b's confirm it, or do not
    for crossing, best in ((0.01, "b"), (0.03, None)):
        ev = _evidence({"a": 0.7, "b": 0.7}, defects=("a",), kind="doubled_walls")
        for a, c in (("a", 0.05), ("b", crossing)):
            ev["algorithms"][a] |= {"scan_crossing": c, "scan_runs": 1}
        v = agreement_verdict(ev, algorithm=["a", "b"], corners=[5, 50])
        assert v["best"] == best, v["confidence"]
        if best:
            assert "a is wrong on its own (defects: doubled_walls" in v["confidence"]
    # a severe kind still decides alone
    ev = _evidence({"a": 0.7, "b": 0.7}, defects=("a",), kind="smeared")
    assert agreement_verdict(ev, algorithm=["a", "b"], corners=[5, 50])["best"] == "b"


def test_a_second_direction_two_programs_draw_is_the_buildings(monkeypatch) -> None:
    """S1 of docs/validity.md ("A second generator the rule was not tuned on: wing
    worlds"; adopted, ``rule.SHARED_DIRECTION``): a ``superposed`` flag is lifted when
    another program's map carries one at the same separation (within 5 degrees where both
    maps have their scans, 3 without), kept
    otherwise."""
    from slamq.verdict import rule

    def wing(seps: dict) -> dict:
        ev = _evidence({"a": 0.9, "b": 0.88, "c": 0.85}, defects=tuple(seps))
        for a, sep in seps.items():
            ev["algorithms"][a]["defects"][f"{a}.pgm"][0]["separation"] = sep
        # the three maps agree (S1a: a lift needs the sharing map to agree)
        ev["min_support"] = 0.6
        ev["consistency"] = {f"{a}.pgm": {f"{b}.pgm": 0.9 for b in "abc" if b != a}
                             for a in "abc"}
        return ev

    cols = {"algorithm": list("abc"), "corners": [100, 200, 300]}
    # the rule before: every map flagged, no name
    assert rule.SHARED_DIRECTION is True
    ev = wing({"a": 31.0, "b": 32.5, "c": 31.5})
    monkeypatch.setattr(rule, "SHARED_DIRECTION", False)
    assert agreement_verdict(ev, **cols)["best"] is None
    monkeypatch.setattr(rule, "SHARED_DIRECTION", True)
    v = agreement_verdict(ev, **cols)
    assert v["best"] == "a", v["confidence"]          # fewest corners, no flag held
    assert any(w.startswith("a's second wall direction (31 deg from the first) is drawn by "
                            "b's map too, which agrees with it: the building's")
               for w in v["warnings"])
    # one program's own direction (a jump by its own angle) stays held against it
    v = agreement_verdict(wing({"a": 31.0, "b": 12.0}), **cols)
    assert v["best"] == "c" and any("a is never named best: defects: superposed" in w
                                    for w in v["warnings"]), v["warnings"]
    v = agreement_verdict(wing({"a": 31.0, "b": 36.5}), **cols)   # 5.5 degrees apart
    assert v["best"] == "c"
    # 4.5 degrees apart (S1a-5s): lifted within 5 where both maps have their scans, not
    # within the 3 of maps alone, nor with the rule before (3 everywhere)
    assert (rule.SHARED_DIRECTION_DEG, rule.SHARED_DIRECTION_DEG_NO_SCANS) == (5.0, 3.0)
    ev = wing({"a": 31.0, "b": 35.5})
    assert agreement_verdict(ev, **cols)["best"] == "c"
    for a in "abc":
        ev["algorithms"][a] |= {"scan_crossing": 0.01, "scan_runs": 1}
    v = agreement_verdict(ev, **cols)
    assert v["best"] == "a", v["confidence"]
    ev["algorithms"]["b"]["scan_crossing"] = math.nan      # b's scans not scored: 3 degrees
    assert agreement_verdict(ev, **cols)["best"] == "c"
    ev["algorithms"]["b"]["scan_crossing"] = 0.01
    monkeypatch.setattr(rule, "SHARED_DIRECTION_DEG", 3.0)
    assert agreement_verdict(ev, **cols)["best"] == "c"
    monkeypatch.setattr(rule, "SHARED_DIRECTION_DEG", 5.0)
    # a flag of another kind on the same map stays
    ev = wing({"a": 31.0, "b": 31.0})
    ev["algorithms"]["a"]["defects"]["a.pgm"].append({"kind": "smeared", "score": 1.0,
                                                      "bbox": [0, 0, 1, 1], "note": ""})
    v = agreement_verdict(ev, **cols)
    assert v["best"] == "b" and any("a is never named best: defects: smeared" in w
                                    for w in v["warnings"]), v["warnings"]


def test_s1a_lifts_only_by_a_map_that_agrees(monkeypatch) -> None:
    """S1a of docs/validity.md (``rule.SHARED_DIRECTION_AGREE``, adopted): the map that
    shares the second direction must also agree with the flagged one (consistency at least
    the evidence's ``min_support``); a match by chance with a map it disagrees with is not
    the building's."""
    from slamq.verdict import rule

    ev = _evidence({"a": 0.9, "b": 0.88, "c": 0.85}, defects=("a", "b"))
    for a, sep in (("a", 31.0), ("b", 32.0)):
        ev["algorithms"][a]["defects"][f"{a}.pgm"][0]["separation"] = sep
    ev["min_support"] = 0.6
    info = ev["algorithms"]
    monkeypatch.setattr(rule, "SHARED_DIRECTION_AGREE", True)
    for c, lifted in ((0.65, {"a": {31.0: "b"}, "b": {32.0: "a"}}), (0.45, {})):
        ev["consistency"] = {"a.pgm": {"b.pgm": c}, "b.pgm": {"a.pgm": c}}
        assert rule.shared_directions(info, ev) == lifted
    assert rule.shared_directions(info) == {}          # no evidence of agreement, no lift
    cols = {"algorithm": list("abc"), "corners": [100, 200, 300]}
    assert agreement_verdict(ev, **cols)["best"] == "c"          # both flags held
    monkeypatch.setattr(rule, "SHARED_DIRECTION_AGREE", False)   # S1: lifted by chance
    assert rule.shared_directions(info, ev) == {"a": {31.0: "b"}, "b": {32.0: "a"}}
    assert agreement_verdict(ev, **cols)["best"] == "a"


@pytest.mark.parametrize("kind", ["superposed", "smeared", "fragmented"])
def test_of_two_maps_one_broken_beyond_doubt_the_other_is_named_placed_or_not(
        kind: str) -> None:
    # spec 9, "two maps, one broken beyond doubt": a severe defect on one map names the
    # other even when the two do not register and the broken map's copies outgrow its area
    ev = _evidence({"a": math.nan, "b": math.nan}, defects=("a",), kind=kind,
                   unplaced=("a", "b"), completeness={"a": 1.0, "b": 0.6})
    v = agreement_verdict(ev, algorithm=["a", "b"], corners=[5, 50])
    assert v["best"] == "b" and v["ranking"] == ["b", "a"], v
    assert v["confidence"].startswith("low: ")
    assert f"a is broken on its own (defects: {kind}" in v["confidence"]
    assert "and b carries no defect flag" in v["confidence"]
    assert "could not be laid over each other" in v["confidence"]
    assert any(w.startswith("a is never named best: defects:") for w in v["warnings"])
    assert not any(w.startswith("b is never named best") for w in v["warnings"])
    # the other map flagged too (by any detector), both broken, or three maps: as before
    for other in ({"b": "doubled_walls"}, {"b": "smeared"}):
        ev = _evidence({"a": math.nan, "b": math.nan}, unplaced=("a", "b"),
                       kinds={"a": kind, **other})
        assert agreement_verdict(ev, algorithm=["a", "b"], corners=[5, 50])["best"] is None
    three = _evidence({"a": math.nan, "b": math.nan, "c": math.nan}, defects=("a",),
                      kind=kind, unplaced=("a", "b", "c"))
    assert agreement_verdict(three, algorithm=list("abc"), corners=[5, 50, 9])["best"] is None
    # with their scans, b's map is called consistent with them only when they confirm it
    for crossing, said in ((0.01, ", consistent with its own scans (1.0% of its beams"),
                           (0.12, "; its own scans do not confirm it: 12.0% of b's beams "
                                  "cross its walls (a's 20.0%)")):
        ev = _evidence({"a": math.nan, "b": math.nan}, defects=("a",), kind=kind,
                       unplaced=("a", "b"))
        for a, c in (("a", 0.2), ("b", crossing)):
            ev["algorithms"][a] |= {"scan_crossing": c, "scan_runs": 1}
        v = agreement_verdict(ev, algorithm=["a", "b"], corners=[5, 50])
        assert v["best"] == "b" and said in v["confidence"], v["confidence"]


def test_ground_truth_still_decides_when_evidence_is_given() -> None:
    ev = _evidence({"a": 0.9, "b": 0.2, "c": 0.9})
    v = agreement_verdict(ev, algorithm=list("abc"), corners=[1, 2, 3],
                          ate_rmse=[0.5, 0.1, 0.3])
    assert v["best"] == "b" and v["basis"] == ["ate_rmse"]


def test_without_a_majority_the_agreeing_group_decides() -> None:
    """Issue 41, item 1: two programs that agree with each other among three that agree
    with nobody: named from the group, confidence low, the others never named; with no
    group it abstains as before."""
    df = pd.DataFrame({"sequence": "s", "algorithm": list("abcde"),
                       "corners": [300, 310, 900, 800, 700], "known": 1000})

    def ev(group: list[str]) -> dict:
        return {"majority": False, "notes": [], "group": group, "algorithms": {
            a: {"support": s, "completeness": 1.0, "placed": True, "runs": 1,
                "flagged_runs": 0, "defects": {}, "in_group": float(a in group),
                "group_support": g if a in group else math.nan}
            for a, s, g in zip("abcde", [0.55, 0.52, 0.3, 0.6, 0.2],
                               [0.99, 0.99, 0, 0, 0])}}

    v = sequence_verdict(summarize(df), "s", ev(["a", "b"]))
    assert v["best"] == "a" and v["ranking"][:2] == ["a", "b"]
    assert v["confidence"].startswith("low:") and "a, b agree with each other" in \
        v["confidence"]
    assert any("d is never named best: not in the group" in w for w in v["warnings"])
    none = sequence_verdict(summarize(df), "s", ev([]))
    assert none["best"] is None and "disagree among themselves" in none["confidence"]


def test_a_programs_identical_reruns_do_not_outvote_two_sound_maps(tmp_path,
                                                                    monkeypatch) -> None:
    """docs/validity.md, "One witness a program": of three programs, each other program is
    one witness of a map and its own reruns none, so three identical reruns of a bent map
    do not outvote two sound maps; with one run a program the support is as before."""
    from slamq.synth import degrade, floor_plan
    from slamq.synth.worldgen import save_world
    from slamq.verdict import evidence as ev_mod

    plan = floor_plan(3)
    maps = {"a": [degrade(plan, "drift", 8.0, seed=1)] * 3,  # bent: 8 deg per 10 m
            "b": [degrade(plan, "specks", 0.001, seed=2)],
            "c": [degrade(plan, "specks", 0.001, seed=3)]}
    rows = [{"map": str(save_world(m, tmp_path / f"{alg}{run}.yaml")), "algorithm": alg,
             "sequence": "s", "run": run, "corners": {"a": 300, "b": 200, "c": 210}[alg]}
            for alg, runs in maps.items() for run, m in enumerate(runs, 1)]
    ok = pd.DataFrame(rows)
    assert ev_mod.ONE_WITNESS_A_PROGRAM
    ev = sequence_evidence(ok, "s", defects=False, scans=False)
    support = {a: e["support"] for a, e in ev["algorithms"].items()}
    assert support["a"] < min(support["b"], support["c"]) - 0.1
    assert sequence_verdict(summarize(ok), "s", ev)["best"] in ("b", "c")
    # counted with its reruns (the rule before), the bent map outvotes the sound ones
    monkeypatch.setattr(ev_mod, "ONE_WITNESS_A_PROGRAM", False)
    before = sequence_evidence(ok, "s", defects=False, scans=False)
    assert before["algorithms"]["a"]["support"] > support["a"] + 0.1
    assert sequence_verdict(summarize(ok), "s", before)["best"] == "a"
    # with one run a program, the support is the same either way
    one = ok.drop_duplicates("algorithm")
    old = sequence_evidence(one, "s", defects=False, scans=False)["algorithms"]
    monkeypatch.setattr(ev_mod, "ONE_WITNESS_A_PROGRAM", True)
    new = sequence_evidence(one, "s", defects=False, scans=False)["algorithms"]
    assert {a: e["support"] for a, e in new.items()} == \
        {a: e["support"] for a, e in old.items()}
