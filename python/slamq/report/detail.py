"""One map's detail page: what was counted on it as layers over the plain map, each
switched on and off by a checkbox (CSS only): the counted corners, the counted enclosed
areas, the comparison with the sequence's ground-truth map (when there is one), the map's
defects and, in a sequence judged without ground truth, its missing walls against the other
maps of the sequence (walls most other maps have where this map sees free space;
informational, off at first, not used by the verdict, docs/validity.md "Missing walls
against the other maps") and, when its record names the recording it was built from, where
the map contradicts its own scans (a heat map of the beams that pass through its walls,
docs/spec.md 7b; off at first); then its numbers, the enclosed-area curve, the trajectory coloured
by ATE and the map being built. Everything drawn comes from
:func:`slamq.verdict.exhibits.map_exhibit`.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from slamq.columns import column, shown_names
from slamq.errors import ParamError, SlamqError
from slamq.report.formatting import format_value
from slamq.report.markup import MapPage, page
from slamq.report.markup import esc as _e
from slamq.verdict.building import Timeline
from slamq.verdict.evidence import MISSING_MIN_LENGTH, split_hit
from slamq.verdict.exhibits import MapExhibit, ScanExhibit
from slamq.verdict.records import usable
from slamq.verdict.rule import halves_miss
from slamq.verdict.trajectory import TrajectoryEvidence

__all__ = ["SCAN_LAYER_COLOURS", "agreeing_group", "building_directions", "detail_page",
           "path_sentence", "run_info", "scan_layer", "standing", "with_unit"]


def _crossing(figures: dict) -> float | None:
    """The crossing share of a map's scan figures, or None when they lack it (records
    scored before it existed).

    Examples
    --------
    >>> _crossing({"crossing_share": 0.021}), _crossing({}), _crossing({"crossing_share": None})
    (0.021, None, None)
    """
    v = figures.get("crossing_share")
    return float(v) if isinstance(v, (int, float)) and v == v else None


def _crossing_clause(figures: dict) -> str:
    """The clause on the beams that came out beyond a wall ('' without the crossing share).

    Examples
    --------
    >>> _crossing_clause({"crossing_share": 0.021})
    ' (2.1% come out into free space beyond the wall: the laser saw through it, not along it)'
    >>> _crossing_clause({})
    ''
    """
    v = _crossing(figures)
    if v is None:
        return ""
    return (f" ({100 * v:.1f}% come out into free space beyond the wall: the laser saw "
            "through it, not along it)")


def detail_page(mp: MapPage, ex: MapExhibit, out: Path, *, gifs: bool, trajectories: bool
                ) -> None:
    """Write ``mp``'s page from what the verdict layer computed of its map (``ex``:
    :func:`slamq.verdict.exhibits.map_exhibit`) and the pictures it shows; ``mp`` gains the
    paths of its pictures, its notes and its defects (the index shows them).

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib
    >>> from PIL import Image
    >>> from slamq.report.markup import MapPage
    >>> from slamq.verdict.exhibits import map_exhibit
    >>> d = pathlib.Path(tempfile.mkdtemp()); (d / "img").mkdir(); (d / "maps").mkdir()
    >>> img = np.full((30, 30), 254, np.uint8); img[8:22, 8:22] = 0
    >>> Image.fromarray(img).save(d / "a.pgm")
    >>> rec = {"map": str(d / "a.pgm"), "algorithm": "a", "sequence": "s", "run": 0}
    >>> mp = MapPage(0, rec, "a", page="maps/a.html")
    >>> detail_page(mp, map_exhibit(rec, gifs=False), d, gifs=False, trajectories=False)
    >>> mp.thumb, (d / mp.page).is_file()
    ('img/a_thumb.png', True)
    """
    from slamq.report.overlays import draw_overlay
    from slamq.report.plots import curve_figure

    rec = mp.record
    sections: list[str] = []
    grid, quality, params = ex.grid, ex.quality, ex.params
    mp.notes.extend(ex.notes)
    if grid is not None and quality is not None and ex.marks is not None:
        u = ex.marks.unknown_value
        ov = draw_overlay(grid, ex.marks, composite=False)  # the page draws its layers
        mp.full = f"img/{mp.slug}.png"
        mp.thumb = f"img/{mp.slug}_thumb.png"
        ov.save(str(out / mp.full), which="plain")
        ov.save(str(out / mp.thumb), max_size=230, which="plain")
        mp.defects = ex.defects
        gt = ex.ground_truth
        sections.append(_map_layers(mp, out, ov, u, grid, gt, ex.scans))
        curve_png = f"img/{mp.slug}_curve.svg"
        curve_figure(list(quality.curve), list(params.sweep_values),
                     int(quality.enclosed_unknown_value), out / curve_png)
        sections.append(
            "<h2>Enclosed areas over the unknown value</h2><p>The sweep of SPEC section 4 "
            "(paper III.C): unknown cells take every value u; the metric is the maximum.</p>"
            f"<p><img src=\"../{curve_png}\" alt=\"enclosed-area curve\"></p>")
        sections.append(_ground_truth_section(gt, out, mp))
        if trajectories:
            sections.append(_trajectory_section(rec, ex.trajectory, grid, out, mp))
        if gifs:
            sections.append(_building_section(ex.building, out, mp))
    rows = "".join(
        f"<tr><th title=\"{_e(k)}\">{_e(_label(k))}</th><td class=\"num\" "
        f"data-field=\"{_e(k)}\">{_e(with_unit(k, rec.get(k)))}</td></tr>"
        for k in _DETAIL_KEYS if k in rec and usable(rec.get(k)))
    files = "".join(
        f"<li>{_e(k)}: <code>{_e(rec.get(k))}</code></li>"
        for k in _FILE_KEYS if k in rec and usable(rec.get(k)))
    notes = "".join(f"<p class=\"warn\">{_e(n)}</p>" for n in mp.notes)
    head = (f"<p><a href=\"../index.html\">&larr; back to the report</a></p>"
            f"<h1>{_e(rec['algorithm'])} on {_e(rec['sequence'])}, run {_e(rec['run'])}</h1>"
            + _standing_block(mp.standing) + _run_block(run_info(rec))
            + f"<ul class=\"sub files\">{files}</ul>{notes}" + _group_block(mp.group)
            + _path_block(mp.path))
    numbers = (f"<div><h2>Numbers</h2><div class=\"scroll\"><table class=\"numbers\">{rows}"
               "</table></div></div>")
    first = sections[0] if sections else ""
    rest = "".join(s for s in sections[1:] if s)
    (out / mp.page).write_text(
        page(f"{rec['algorithm']} / {rec['sequence']} / run {rec['run']}",
             head + f"<div class=\"top\">{numbers}{first}</div>" + rest), encoding="utf-8")


#: The numbers a detail page lists and the files it names (slamq.columns: "detail", "files").
_DETAIL_KEYS = shown_names("detail")
_FILE_KEYS = shown_names("files")


def _unit(key: str) -> str:
    try:
        return column(key).unit
    except (KeyError, ParamError):
        return ""


def _label(key: str) -> str:
    try:
        return column(key).label or key
    except (KeyError, ParamError):
        return key


def with_unit(key: str, x: Any) -> str:
    """A record's value as a detail page prints it: integers whole, else 6 significant
    digits, then the column's unit (:mod:`slamq.columns`).

    Examples
    --------
    >>> with_unit("gt_dyaw", -1.80364), with_unit("gt_outside", 539), with_unit("corners", 7)
    ('-1.80364 deg', '539 cells', '7')
    """
    unit = _unit(key)
    text = _fmt_cell(x)
    return f"{text} {unit}" if unit else text


def _fmt_cell(x: Any) -> str:
    if isinstance(x, (int, np.integer)):
        return str(int(x))
    if isinstance(x, (float, np.floating)):
        return f"{float(x):.6g}"
    return str(x)


def standing(rec: dict, ranking: Any, summary: Any = None,
             evidence: dict[str, Any] | None = None) -> dict[str, str]:
    """Where a map's algorithm stands in its sequence's verdict, as sentences for its detail
    page: ``rank`` (its place in the verdict's ranking), ``verdict`` (the sequence's
    sentence), ``support`` (the figure the verdict ranks by, for this run and the
    algorithm) and ``reason`` (why it was, or was not, named best).

    Parameters
    ----------
    rec : dict
        The map's record (``algorithm``, ``sequence``, the metric columns).
    ranking : slamq.verdict.ranking.SequenceRanking
        Its sequence's ranking (with the verdict).
    summary : pandas.DataFrame, optional
        :attr:`slamq.verdict.judge.Judgement.summary` (the algorithms' means).
    evidence : dict, optional
        The sequence's evidence when the maps' agreement judged it.

    Examples
    --------
    >>> import pandas as pd
    >>> from slamq.verdict.judge import judge
    >>> ok = pd.DataFrame({"sequence": "s", "algorithm": ["a", "b"], "run": 0,
    ...                    "ate_rmse": [0.1, 0.2], "corners": [3, 5]})
    >>> j = judge(ok)
    >>> st = standing(ok.iloc[1].to_dict(), j.rankings["s"], j.summary)
    >>> st["rank"]
    'b ranks 2 of 2 on s.'
    >>> st["reason"]
    'Not named best: a ranks ahead of it by ATE RMSE (0.1 m against 0.2 m).'
    """
    from slamq.verdict.rule import basis_name, verdict_sentence

    alg, seq = str(rec["algorithm"]), str(rec["sequence"])
    v = ranking.verdict
    basis = list(v.get("basis") or [])
    key = basis[0] if basis else None
    out = {"verdict": verdict_sentence(v)}
    if alg in ranking.ground_truths:
        out["rank"] = f"{alg} is the reference map of {seq}: it is not ranked."
    elif alg in ranking.ranked:
        out["rank"] = (f"{alg} ranks {ranking.ranked.index(alg) + 1} of {len(ranking.ranked)}"
                       f" on {seq}.")
    else:
        out["rank"] = f"{alg} is not ranked on {seq}: it has no {basis_name(key)}."

    def mean(a: str, k: str) -> float:
        try:
            return float(summary.loc[(seq, a), f"{k}_mean"])
        except (AttributeError, KeyError, TypeError, ValueError):
            return math.nan

    if key == "agreement" and evidence is not None:
        info = evidence.get("algorithms", {})
        mine = info.get(alg, {}).get("support", math.nan)
        top = max((e["support"] for e in info.values() if math.isfinite(e["support"])),
                  default=math.nan)
        if math.isfinite(mine):
            out["support"] = (f"Support {mine:.2f}: the median over {alg}'s runs of how far "
                              "the other maps confirm its walls (of three programs or more, "
                              "each other program once, never its own reruns; best of "
                              f"{seq}: {top:.2f}).")
        else:
            out["support"] = f"No support figure: the other maps could not place {alg}'s."
    elif key is not None:
        this = _num(rec.get(key))
        avg = mean(alg, key)
        parts = []
        if math.isfinite(this):
            parts.append(f"this run {_short(key, this)}")
        if math.isfinite(avg):
            parts.append(f"{alg}'s mean {_short(key, avg)}")
        best = v.get("best")
        if best and best != alg and math.isfinite(mean(best, key)):
            parts.append(f"{best}'s mean {_short(key, mean(best, key))}")
        out["support"] = (f"The verdict ranks by {basis_name(key)}: " + ", ".join(parts) + "."
                          if parts else f"The verdict ranks by {basis_name(key)}.")
    best = v.get("best")
    named = [w for w in v.get("warnings", []) if w.startswith((f"{alg} is never named best",
                                                               f"{alg}'s map knows"))]
    confidence = str(v.get("confidence", ""))
    if alg in ranking.ground_truths:
        out["reason"] = "A reference map is never named best."
    elif best == alg:
        # the level and its record; the verdict's sentence just above gives the reasons
        out["reason"] = f"Named best of {seq} (confidence {confidence.split('; ')[0]})."
    elif named:
        out["reason"] = f"Not named best: {named[0]}."
    elif best is None:
        out["reason"] = (f"No algorithm is named best on {seq}: "
                         f"{confidence.removeprefix('none: ')}.")
    elif alg not in ranking.ranked:
        out["reason"] = f"Not named best: not ranked, without {basis_name(key)}."
    else:
        by = " then ".join(basis_name(b) for b in basis)
        figures = ""
        if key not in (None, "agreement") and math.isfinite(mean(best, key)) \
                and math.isfinite(mean(alg, key)):
            figures = (f" ({_short(key, mean(best, key))} against "
                       f"{_short(key, mean(alg, key))})")
        out["reason"] = f"Not named best: {best} ranks ahead of it by {by}{figures}."
    return out


def _short(key: str, x: float) -> str:
    """``x`` with the field's unit, to 3 significant digits (for sentences)."""
    unit = _unit(key)
    return f"{format_value(x)} {unit}" if unit else format_value(x)


def _num(x: Any) -> float:
    try:
        return float(x)
    except (TypeError, ValueError):
        return math.nan


def _standing_block(st: dict[str, str] | None) -> str:
    if not st:
        return ""
    return ("<section class=\"standing\" id=\"standing\">" + "".join(
        f"<p class=\"standing-{k}\">{_e(st[k])}</p>" for k in ("rank", "verdict", "support",
                                                               "reason")
        if st.get(k)) + "</section>")


def agreeing_group(rec: dict, evidence: dict[str, Any] | None,
                   pages: dict[str, str] | None = None,
                   labels: dict[str, str] | None = None) -> dict[str, Any] | None:
    """A map's place in the agreeing group of its sequence (docs/spec.md section 9: of the
    sets of maps whose every pair has a consistency of at least ``min_support``, the one of
    the most programs, then maps),
    as its detail page says it: whether the map is in the group, the group's members with
    this map's consistency against each, and what that means.

    Parameters
    ----------
    rec : dict
        The map's record (``map``, ``algorithm``, ``sequence``, ``run``).
    evidence : dict or None
        Its sequence's :func:`slamq.verdict.evidence.sequence_evidence` (None when the
        sequence was not judged by the maps' agreement: then None).
    pages : dict, optional
        The detail page (path from the site root) of each map that has one, by map path:
        the members link to theirs.
    labels : dict, optional
        How to name each map of the sequence, by map path (``"program, run N"``): the maps
        outside the group this map agrees with are named so (by file name otherwise,
        which says little where every run writes ``map.yaml``).

    Returns
    -------
    dict or None
        ``{"status", "sentence", "members"}``: ``status`` is ``"member"``, ``"outside"``
        (agrees with some map, not with the whole group), ``"alone"`` (agrees with no
        other map), ``"none"`` (the sequence has no agreeing group) or ``"absent"`` (the
        map took no part in the comparison); ``members`` one dict per map of the group
        (``label``, ``page`` or None, ``consistency`` with this map, NaN for itself,
        ``self``).

    Examples
    --------
    >>> ev = {"min_support": 0.6, "majority": False,
    ...       "group_maps": [{"map": "a.pgm", "algorithm": "a", "run": 1},
    ...                      {"map": "b.pgm", "algorithm": "b", "run": 1}],
    ...       "consistency": {"a.pgm": {"b.pgm": 0.99, "c.pgm": 0.1},
    ...                       "b.pgm": {"a.pgm": 0.99, "c.pgm": 0.2},
    ...                       "c.pgm": {"a.pgm": 0.1, "b.pgm": 0.2}}}
    >>> rec = {"map": "a.pgm", "algorithm": "a", "sequence": "s", "run": 1}
    >>> g = agreeing_group(rec, ev, {"b.pgm": "maps/b.html"})
    >>> g["status"], g["sentence"].split(":")[0]
    ('member', 'a (run 1) is in the agreeing group of s')
    >>> [(m["label"], m["page"], m["consistency"]) for m in g["members"]][1]
    ('b, run 1', 'maps/b.html', 0.99)
    >>> print(agreeing_group(dict(rec, map="c.pgm", algorithm="c"), ev)["sentence"])
    ... # doctest: +NORMALIZE_WHITESPACE
    c (run 1) is not in the agreeing group of s: it agrees with no other map (no
    consistency reaches 0.6): evidence of nothing.
    >>> ev["consistency"]["c.pgm"]["d.pgm"] = 1.0
    >>> print(agreeing_group(dict(rec, map="c.pgm", algorithm="c"), ev, None,
    ...                      {"d.pgm": "c, run 2"})["sentence"])
    ... # doctest: +NORMALIZE_WHITESPACE
    c (run 1) is not in the agreeing group of s: it agrees with c, run 2 (1.00) but not
    with every map of the group, so the group does not confirm it.
    """
    if evidence is None:
        return None
    alg, seq, run = str(rec["algorithm"]), str(rec["sequence"]), rec.get("run")
    me = str(rec.get("map", ""))
    who = f"{alg} (run {run})"
    least = float(evidence.get("min_support", 0.6))
    mine = evidence.get("consistency", {}).get(me)
    group = list(evidence.get("group_maps", []))
    pages = pages or {}
    members = [{"label": f"{m['algorithm']}, run {m['run']}", "map": str(m["map"]),
                "page": pages.get(str(m["map"])) if str(m["map"]) != me else None,
                "consistency": math.nan if str(m["map"]) == me
                else _num((mine or {}).get(str(m["map"]))),
                "self": str(m["map"]) == me} for m in group]
    if mine is None:
        return {"status": "absent", "members": members, "sentence": (
            f"{who} took no part in the comparison of the maps of {seq} (at most the first "
            "three runs of each program are compared, and a map that cannot be read is left "
            "out): the agreeing group says nothing of it.")}
    if not group:
        return {"status": "none", "members": [], "sentence": (
            f"There is no agreeing group in {seq}: no maps of two programs agree "
            f"(consistency at least {least:g}; a program's runs agreeing with each other "
            "confirm nothing), so no map is confirmed by another program's.")}
    role = (f" Most maps of {seq} confirm each other: the verdict weighs each map's support, "
            "and the group changes nothing." if evidence.get("majority") else
            f" No majority of the maps of {seq} confirm each other: the verdict names its "
            "best from this group.")
    if any(m["self"] for m in members):
        others = [m for m in group if str(m["map"]) != me and str(m["algorithm"]) != alg]
        own = sum(1 for m in group if str(m["map"]) != me and str(m["algorithm"]) == alg)
        names = sorted({str(m["algorithm"]) for m in others})
        what = (f"confirmed by {len(others)} map{'s' if len(others) != 1 else ''} from "
                f"{'other programs' if len(names) > 1 else 'another program'} "
                f"({', '.join(names)})" if others else
                "confirmed by no map from another program")
        if own:
            what += f" and {own} other run{'s' if own != 1 else ''} of {alg}"
        return {"status": "member", "members": members, "sentence": (
            f"{who} is in the agreeing group of {seq}: {what}, every pair's consistency at "
            f"least {least:g}." + role)}
    agrees = sorted(((v, o) for o, v in mine.items() if math.isfinite(v) and v >= least),
                    reverse=True)
    if not agrees:
        return {"status": "alone", "members": members, "sentence": (
            f"{who} is not in the agreeing group of {seq}: it agrees with no other map (no "
            f"consistency reaches {least:g}): evidence of nothing.")}
    label = {**(labels or {}), **{str(m["map"]): m["label"] for m in members}}
    shown = ", ".join(f"{label.get(o, Path(o).name)} ({v:.2f})" for v, o in agrees)
    return {"status": "outside", "members": members, "sentence": (
        f"{who} is not in the agreeing group of {seq}: it agrees with {shown} but not with "
        f"every map of the group, so the group does not confirm it.")}


def building_directions(rec: dict, evidence: dict[str, Any] | None) -> dict[float, str]:
    """The ``superposed`` flags of the map that the verdict does not hold against it
    because another program's map draws the same second wall direction (docs/spec.md
    section 9, "A second wall direction two programs draw"): each flag's separation
    (degrees, rounded to 0.01) with the program whose map shares it. Empty when none is
    lifted or the sequence was not judged by its maps.

    Examples
    --------
    >>> flag = lambda p, s: {p: [{"kind": "superposed", "separation": s}]}
    >>> ev = {"algorithms": {"a": {"defects": flag("a.pgm", 31.0)},
    ...                      "b": {"defects": flag("b.pgm", 32.5)}},
    ...       "min_support": 0.6, "consistency": {"a.pgm": {"b.pgm": 0.9}}}
    >>> building_directions({"map": "a.pgm", "algorithm": "a"}, ev)
    {31.0: 'b'}
    >>> building_directions({"map": "a.pgm", "algorithm": "a"}, None)
    {}
    """
    from slamq.verdict.rule import shared_directions, superposed_separations

    if evidence is None:
        return {}
    alg, path = str(rec.get("algorithm")), str(rec.get("map"))
    info = evidence.get("algorithms", {})
    lifted = shared_directions(info, evidence).get(alg, {})
    mine = info.get(alg, {}).get("defects", {}).get(path, [])
    seps = set(superposed_separations({"defects": {path: mine}}))
    return {round(float(v), 2): b for v, b in lifted.items() if v in seps}


def _defect_note(d: dict, mp: MapPage) -> str:
    """A defect's note on the detail page, with why a lifted ``superposed`` flag is not
    held against the map."""
    from slamq.verdict.rule import (
        SHARED_DIRECTION_AGREE,
        SHARED_DIRECTION_DEG,
        SHARED_DIRECTION_DEG_NO_SCANS,
    )

    other = mp.lifted_by(d)
    if other is None:
        return _e(d["note"])
    return (f"{_e(d['note'])}<br><b>The building's, not held against this map:</b> "
            f"{_e(other)}'s map draws this map's second direction "
            f"({float(d['separation']):.0f} deg from the first) too, within "
            f"{SHARED_DIRECTION_DEG:g} deg where both maps' scans were scored, "
            f"{SHARED_DIRECTION_DEG_NO_SCANS:g} without,"
            + (" and agrees with this map" if SHARED_DIRECTION_AGREE else "")
            + " (docs/spec.md section 9).")


def path_sentence(rec: dict, evidence: dict[str, Any] | None) -> str | None:
    """How far the path of the map's program travels against the other programs' paths
    (docs/spec.md 7d: its shortfall, the median over pairs of runs, and along the
    corridors beyond elsewhere), and whether the verdict weighs it (only where the
    recording's scans see walls in one direction, section 9), as the map's detail page
    says it; None without a figure.

    Examples
    --------
    >>> ev = {"degenerate_share": 0.058, "algorithms": {
    ...     "icp": {"shortfall": 0.036, "shortfall_against": "rbpf"},
    ...     "rbpf": {"shortfall": -0.02, "shortfall_against": "icp"}}}
    >>> print(path_sentence({"algorithm": "icp"}, ev))  # doctest: +NORMALIZE_WHITESPACE
    icp's path travels 3.6% less than rbpf's over the same windows of 10 s (docs/spec.md
    7d). 5.8% of the recording's scans see walls in one direction only, so the verdict
    weighs it: it names no map whose path is 3% or more shorter than another program's,
    unless that path's halves set it apart from every other path (docs/spec.md section
    9).
    >>> print(path_sentence({"algorithm": "rbpf"}, {**ev, "degenerate_share": 0.0}))
    ... # doctest: +NORMALIZE_WHITESPACE
    rbpf's path travels at least 2.0% more than every other program's (the nearest: icp's)
    over the same windows of 10 s (docs/spec.md 7d). The recording's scans see walls in
    more than one direction (0.0% see one only), so the verdict does not weigh it.
    >>> ev["algorithms"]["icp"].update(corridor_shortfall=-0.004,
    ...                                corridor_shortfall_against="rbpf")
    >>> print(path_sentence({"algorithm": "icp"}, ev))  # doctest: +NORMALIZE_WHITESPACE
    icp's path travels 3.6% less than rbpf's over the same windows of 10 s (docs/spec.md
    7d). Along the corridors, beyond their difference elsewhere, it travels at least 0.4%
    more than every other program's (the nearest: rbpf's). 5.8% of the recording's scans
    see walls in one direction only, so the verdict weighs both: it names no map whose path
    is 3% or more shorter than another program's over the whole run and along the
    corridors, unless that path's halves set it apart from every other path (docs/spec.md
    section 9).
    >>> for a, split, hit in [("icp", 0.02, 0.3), ("rbpf", 0.1, 0.1), ("gs", 0.2, 0.1)]:
    ...     ev["algorithms"].setdefault(a, {}).update(scan_split=split, split_hit=hit)
    >>> print(path_sentence({"algorithm": "icp"}, ev).split(". ")[-1])
    ... # doctest: +NORMALIZE_WHITESPACE
    5.8% of the recording's scans see walls in one direction only, so the verdict weighs
    both: it names no map whose path is 3% or more shorter than another program's over the
    whole run and along the corridors, unless that path's halves set it apart from every
    other path (docs/spec.md section 9), as icp's do: every other path's halves cross each
    other's walls at least 1.5x as often where they meet, so none of them says how far the
    robot went.
    >>> path_sentence({"algorithm": "x"}, ev), path_sentence({"algorithm": "icp"}, None)
    (None, None)
    """
    from slamq.verdict.rule import (
        CORRIDOR_TRAVEL,
        SHORTFALL,
        SPLIT_PRECISION_TRAVEL,
        one_direction_share,
        travel_spared,
    )
    from slamq.verdict.travel import WINDOW_S

    if evidence is None:
        return None
    alg = str(rec.get("algorithm"))
    e = evidence.get("algorithms", {}).get(alg, {})
    short, other = _num(e.get("shortfall")), e.get("shortfall_against")
    if not math.isfinite(short) or other is None:
        return None
    said = (f"{alg}'s path {_travels(short, other)} over the same windows of "
            f"{WINDOW_S:g} s (docs/spec.md 7d).")
    share = _num(evidence.get("degenerate_share"))
    if not math.isfinite(share):
        return said + " No recording was measured, so the verdict does not weigh it."
    if one_direction_share(evidence) is None:
        return (said + " The recording's scans see walls in more than one direction "
                f"({100 * share:.1f}% see one only), so the verdict does not weigh it.")
    # the exemption of section 9 (P1c): a path whose halves set it apart is not held back
    unless = ""
    if SPLIT_PRECISION_TRAVEL is not None:
        unless = (", unless that path's halves set it apart from every other path "
                  "(docs/spec.md section 9)")
        if (spared := travel_spared(evidence.get("algorithms", {}), alg)) is not None:
            unless += f", as {alg}'s do: {spared}"
    along = _num(e.get("corridor_shortfall"))
    if CORRIDOR_TRAVEL == "both" and math.isfinite(along):
        return (said + " Along the corridors, beyond their difference elsewhere, it "
                f"{_travels(along, e.get('corridor_shortfall_against'))}. "
                f"{100 * share:.1f}% of the recording's scans see walls in one direction "
                "only, so the verdict weighs both: it names no map whose path is "
                f"{SHORTFALL:.0%} or more shorter than another program's over the whole "
                f"run and along the corridors{unless}.")
    return (said + f" {100 * share:.1f}% of the recording's scans see walls in one "
            "direction only, so the verdict weighs it: it names no map whose path is "
            f"{SHORTFALL:.0%} or more shorter than another program's{unless}.")


def _travels(short: float, other: Any) -> str:
    """How far a path travels against ``other``'s, from its shortfall (the largest over
    the other programs, so a negative one is against the nearest of them).

    Examples
    --------
    >>> _travels(0.036, "b"), _travels(0.0002, "b")
    ("travels 3.6% less than b's", "travels as far as b's (within 0.1%)")
    >>> _travels(-0.003, "b")
    "travels at least 0.3% more than every other program's (the nearest: b's)"
    """
    if abs(short) < 0.0005:
        return f"travels as far as {other}'s (within 0.1%)"
    if short > 0:
        return f"travels {100 * short:.1f}% less than {other}'s"
    return (f"travels at least {100 * abs(short):.1f}% more than every other program's "
            f"(the nearest: {other}'s)")


def _path_block(sentence: str | None) -> str:
    """The path section of a detail page (:func:`path_sentence`)."""
    if not sentence:
        return ""
    return ("<section class=\"path\" id=\"path\"><h2>Its path against the other "
            f"programs'</h2><p>{_e(sentence)}</p></section>")


def _group_block(g: dict[str, Any] | None) -> str:
    """The agreeing-group section of a detail page (:func:`agreeing_group`)."""
    if not g:
        return ""
    rows = []
    for m in g["members"]:
        name = (f"<a href=\"../{_e(m['page'])}\">{_e(m['label'])}</a>" if m["page"]
                else _e(m["label"]))
        if m["self"]:
            name, value = f"<b>{name}</b> (this map)", "&ndash;"
        elif math.isfinite(m["consistency"]):
            value = f"{m['consistency']:.3f}"
        else:
            value = "no overlap"
        rows.append(f"<tr><td>{name}</td><td class=\"num\">{value}</td></tr>")
    table = ("<div class=\"scroll\"><table class=\"group-members\"><tr><th>map of the "
             "group</th><th>consistency with this map</th></tr>" + "".join(rows)
             + "</table></div>") if rows else ""
    return (f"<section class=\"group\" id=\"group\" data-status=\"{_e(g['status'])}\">"
            f"<h2>Agreeing group</h2><p class=\"group-status\">{_e(g['sentence'])}</p>"
            + table + "</section>")


def run_info(rec: dict) -> dict[str, Any] | None:
    """The ``run.json`` that ``slamq run`` wrote for the map's run (the first one in the
    map's folder or up to three folders above it whose ``map`` is this map), or None.

    Examples
    --------
    >>> run_info({"map": "/nonexistent/map.yaml"}) is None
    True
    """
    import json

    if not usable(rec.get("map")):
        return None
    path = Path(str(rec["map"]))
    for folder in list(path.parents)[:4]:
        f = folder / "run.json"
        try:
            data = json.loads(f.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            continue
        if isinstance(data, dict) and str(data.get("map", "")) == str(path):
            return data
    return None


def _run_block(info: dict[str, Any] | None) -> str:
    """The run's command, outcome, wall and CPU time and peak memory (``run.json``)."""
    if info is None:
        return ""
    cmd = info.get("command")
    if isinstance(cmd, list):   # as the config gives it ({output} and the like unexpanded)
        shown = " ".join(str(c) for c in cmd)
    elif isinstance(cmd, dict):  # a ROS recipe: one command per step
        shown = "; ".join(f"{k}: {' '.join(map(str, v)) if isinstance(v, list) else v}"
                          for k, v in cmd.items())
    else:
        shown = str(cmd or "")
    facts = []
    wall, rss = _num(info.get("wall")), _num(info.get("max_rss_kb"))
    cpu = _num(info.get("user_cpu")) + _num(info.get("sys_cpu"))
    if math.isfinite(wall):
        facts.append(f"wall time {wall:.3g} s")
    if math.isfinite(cpu):
        facts.append(f"CPU time {cpu:.3g} s")
    if math.isfinite(rss):
        facts.append(f"peak memory {rss / 1024:.1f} MiB")
    outcome = str(info.get("outcome", ""))
    return ("<section class=\"run\" id=\"run\"><p>The run (<code>slamq run</code>, its "
            f"<code>run.json</code>): {_e(outcome)}" + (f"; {_e(', '.join(facts))}" if facts
                                                        else "") + ".</p>"
            + (f"<p>Command: <code>{_e(shown)}</code></p>" if shown else "") + "</section>")


_GT_KINDS = (("matched", "ground-truth walls the map has"),
             ("missing", "ground-truth walls the map lacks"),
             ("ghost", "walls only the map has"))


def _gt_swatches() -> str:
    from slamq.report.comparison import COMPARISON_COLOURS

    return "".join(
        f"<span><i class=\"swatch\" style=\"background:rgb{COMPARISON_COLOURS[k]}\"></i> "
        f"{label}</span>" for k, label in _GT_KINDS)


def _ground_truth_section(gt: tuple[Any, Any] | None, out: Path, mp: MapPage) -> str:
    """The map aligned over its sequence's ground-truth map, on the ground truth's grid."""
    if gt is None:
        return ""
    from slamq.report.comparison import write_comparison_png

    c = gt[0]
    png = f"img/{mp.slug}_gt.png"
    write_comparison_png(out / png, c)
    return (
        "<h2>Against the ground-truth map</h2><p>The map aligned (" + _e(c.align) +
        f": dx {c.dx:+.3f} m, dy {c.dy:+.3f} m, dyaw {c.dyaw:+.2f}&deg;) and resampled onto "
        f"the ground truth's grid; a wall matches within {c.tolerance:.3g} m. F1 "
        f"{c.f1:.3f}, chamfer {c.chamfer:.3f} m (docs/spec.md section 7). The same "
        "comparison is the <i>ground truth</i> layer of the map above, in the map's own "
        "frame.</p>"
        f"<p class=\"legend\">{_gt_swatches()}</p>"
        f"<p class=\"big\"><a href=\"../{png}\"><img src=\"../{png}\" "
        "alt=\"map over the ground truth\"></a></p>")


_DEFECT_COLOURS = ("#ff00ff", "#ff8800", "#00c8ff", "#ffd400", "#8a2be2", "#00b050")


def _map_layers(mp: MapPage, out: Path, ov: Any, u: int, grid: Any,
                gt: tuple[Any, Any] | None, scans: Any = None) -> str:
    """The map with its layers (corners, enclosed areas, ground truth, defects, missing
    walls, its own scans), each shown or hidden by a checkbox (CSS only:
    ``.layers:has(#show-X:not(:checked)) .layer-X``)."""
    from slamq.report.overlays import palette_image

    rows, cols = ov.cells
    r0, c0 = ov.offset
    h, w = ov.grey.shape[:2]
    view = f"{c0} {r0} {cols} {rows}"  # SVG user units = map cells
    layers: list[str] = []
    toggles: list[str] = []

    def toggle(key: str, label: str, on: bool, enabled: bool = True) -> None:
        toggles.append(
            f"<label for=\"show-{key}\"><input type=\"checkbox\" id=\"show-{key}\" "
            f"data-layer=\"{key}\"{' checked' if on and enabled else ''}"
            f"{'' if enabled else ' disabled'}>{label}</label>")

    if ov.n_regions:
        png = f"img/{mp.slug}_regions.png"
        ov.save(str(out / png), which="regions")
        layers.append(f"<img class=\"layer layer-regions\" src=\"../{png}\" alt=\"\">")
    toggle("regions", f"<i class=\"swatch\"></i> {ov.n_regions} enclosed areas "
           f"(unknown cells set to u = {u})", False, ov.n_regions > 0)
    radius = max(1.5, max(rows, cols) / 110.0)
    rings = "".join(f"<circle cx=\"{cc + 0.5:.6g}\" cy=\"{rr + 0.5:.6g}\" r=\"{radius:.4g}\"/>"
                    for rr, cc in ov.corners)
    layers.append(
        f"<svg class=\"layer layer-corners\" viewBox=\"{view}\" preserveAspectRatio=\"none\">"
        f"<g fill=\"none\" stroke=\"red\" stroke-width=\"{radius / 3:.4g}\">{rings}</g></svg>")
    toggle("corners", f"<i class=\"ring\"></i> {ov.n_corners} corners", False,
           ov.n_corners > 0)
    if gt is not None:
        from slamq.report.comparison import ground_truth_layer_colours, ground_truth_layer_index

        png = f"img/{mp.slug}_gtlayer.png"
        index = ground_truth_layer_index(gt[0], grid, gt[1], offset=(r0, c0),
                                         shape=(rows, cols), scale=ov.scale)
        palette_image(index, ground_truth_layer_colours()).save(out / png)
        layers.append(f"<img class=\"layer layer-gt\" src=\"../{png}\" alt=\"\">")
        toggle("gt", f"ground truth (F1 {gt[0].f1:.3f})", False)
    if mp.defects:
        size = max(rows, cols) / 45.0
        boxes = []
        for i, d in enumerate(mp.defects):
            a, b, c, e = d["bbox"]
            colour = _DEFECT_COLOURS[i % len(_DEFECT_COLOURS)]
            boxes.append(
                f"<g class=\"defect\" data-kind=\"{_e(d['kind'])}\"><title>{_e(d['kind'])}: "
                f"{_e(d['note'])}</title><rect x=\"{a:.6g}\" y=\"{b:.6g}\" "
                f"width=\"{max(c - a, 0.5):.6g}\" height=\"{max(e - b, 0.5):.6g}\" "
                f"fill=\"none\" stroke=\"{colour}\" stroke-width=\"{size / 6:.4g}\"/>"
                f"<text x=\"{a:.6g}\" y=\"{max(b - size / 4, r0 + size):.6g}\" "
                f"font-size=\"{size:.4g}\" fill=\"{colour}\" stroke=\"#000\" "
                f"stroke-width=\"{size / 14:.4g}\" paint-order=\"stroke\">{i + 1} "
                f"{_e(d['kind'])}</text></g>")
        layers.append(
            f"<svg class=\"layer layer-defects\" viewBox=\"{view}\" "
            f"preserveAspectRatio=\"none\">{''.join(boxes)}</svg>")
    toggle("defects", f"{len(mp.defects)} defect{'' if len(mp.defects) == 1 else 's'}", False,
           bool(mp.defects))
    legend = (f"<p class=\"legend gt-legend\">ground-truth layer: {_gt_swatches()}</p>"
              if gt is not None else "")
    if mp.missing is not None:
        layer, label, legend_missing = _missing_layer(mp.missing, (c0, r0, cols, rows))
        if layer:
            layers.append(layer)
        toggle("missing", label, False, bool(mp.missing))
        legend += legend_missing
    if isinstance(scans, ScanExhibit):
        png = f"img/{mp.slug}_scans.png"
        palette_image(scan_layer(scans.density, offset=(r0, c0), shape=(rows, cols),
                                 scale=ov.scale), SCAN_LAYER_COLOURS).save(out / png)
        layers.append(f"<img class=\"layer layer-scans\" src=\"../{png}\" alt=\"\">")
        f = scans.figures
        crossing = _crossing(f)
        toggle("scans", "<i class=\"heat\"></i> against its own scans: " + (
               f"{100 * crossing:.1f}% of its beams cross its walls" if crossing is not None else
               f"{100 * f['violation_share']:.1f}% of its beams pass through its walls"),
               False, bool(scans.density.max() > 0))
        legend += (
            "<p class=\"legend scans-legend\"><i class=\"heat\"></i> <b>Its own scans</b>: "
            f"{f['scans']} scans of {_e(scans.recording)} ({f['beams']} beams) placed at the "
            "run's trajectory; red where its beams pass through walls of the map and come "
            "out into free space beyond them (the darker, the more; a beam that only grazes "
            f"a wall is not drawn): {100 * f['violation_share']:.1f}% of the beams per scan "
            f"touch a wall before their end{_crossing_clause(f)}, "
            f"{100 * f['hit_share']:.1f}% end on a wall of the map "
            "(docs/spec.md 7b; the verdict weighs the beams that come out beyond a wall, "
            "and never names a map much less consistent with its scans than the "
            "sequence's most consistent one).</p>" + _split_legend(scans.split))
    elif isinstance(scans, Exception):
        mp.notes.append(f"not scored against its own scans: {scans}")
    table = ""
    if mp.defects:
        table = ("<div class=\"scroll\"><table class=\"defects\"><tr><th>#</th><th>kind</th>"
                 "<th>cells [col0, row0, col1, row1]</th><th>note</th></tr>" + "".join(
                     f"<tr><td>{i + 1}</td><td>{_e(d['kind'])}</td><td>"
                     f"{_e(', '.join(format_value(v) for v in d['bbox']))}</td>"
                     f"<td>{_defect_note(d, mp)}</td></tr>"
                     for i, d in enumerate(mp.defects))
                 + "</table></div>")
    return (
        "<div class=\"mapcol\"><h2>The map</h2><p class=\"sub\">unknown cells grey, occupied "
        "black, free white; north up. Layers (all off at first: tick one to draw it over "
        "the map):</p><div class=\"layers\">"
        f"<p class=\"toggles\">{' '.join(toggles)}</p><div class=\"stack\">"
        f"<a href=\"../{mp.full}\"><img class=\"base\" src=\"../{mp.full}\" width=\"{w}\" "
        f"height=\"{h}\" alt=\"the map\"></a>"
        f"{''.join(layers)}</div></div>{legend}{table}</div>")


def _split_legend(split: dict[str, Any] | None) -> str:
    """What the page says of the run's path against its own scans split in time
    (docs/spec.md 7e), which the verdict weighs beside the map's own figure.

    Examples
    --------
    >>> _split_legend({"split_crossing": 0.012, "crossing_1": 0.01, "crossing_2": 0.014,
    ...                "tested": 600})[:80]
    '<p class="legend split-legend"><b>Its path, its scans split in time</b>: 1.2% of'
    >>> _split_legend(None)[-63:]
    'not be scored (fewer than two scans placed, or unreadable).</p>'
    """
    if split is None or not math.isfinite(float(split.get("split_crossing", math.nan))):
        return ("<p class=\"legend split-legend\"><b>Its path, its scans split in time</b>: "
                "could not be scored (fewer than two scans placed, or unreadable).</p>")
    meet, hit = "", split_hit(split)
    if math.isfinite(hit):
        cross = halves_miss(float(split["split_crossing"]), hit)
        meet = (f" The halves meet on {100 * hit:.1f}% of the beams (beams "
                "ending on the walls the other half draws): a low share confirms a path only "
                "where its halves meet at least two thirds as often as the best-meeting "
                "path's, as a wrong loop that never comes back over its start tests little. "
                f"Of the beams with which the halves meet each other's walls, {100 * cross:.1f}%"
                " cross them rather than end on them: where the maps disagree, a path 1.5x "
                "below every other's on this share names its program.")
    return (
        "<p class=\"legend split-legend\"><b>Its path, its scans split in time</b>: "
        f"{100 * split['split_crossing']:.1f}% of the beams cross the walls the other half "
        "of the run draws at the run's trajectory (earlier half against the later "
        f"{100 * split['crossing_1']:.1f}%, later against the earlier "
        f"{100 * split['crossing_2']:.1f}%; {split['tested']} scans scored; the map above "
        "is not read). A wrong path draws walls in one half that the other half's beams "
        "see through; the verdict never names a program whose path is much less "
        f"consistent than the sequence's most consistent one (docs/spec.md 7e and 9).{meet}"
        "</p>")


_MISSING_COLOUR = "#e00000"


#: The heat map's colours: index 0 transparent, then red, ever more opaque.
SCAN_LAYER_COLOURS = [(0, 0, 0, 0)] + [(220, 0, 0, 60 + 195 * k // 7) for k in range(8)]


def scan_layer(density: np.ndarray, *, offset: tuple[int, int], shape: tuple[int, int],
               scale: int) -> np.ndarray:
    """The heat map of :func:`slamq.verdict.exhibits.violation_density` over the picture of
    the map (its crop ``offset`` and ``shape`` in cells, and its ``scale`` in pixels per
    cell), as indices into :data:`SCAN_LAYER_COLOURS`: 0 where no beam crossed a wall, else
    1 to 8, the denser the higher (a palette PNG, as the other layers).

    Examples
    --------
    >>> d = np.zeros((4, 4), np.float32); d[1, 2] = 1.0; d[2, 1] = 0.1
    >>> scan_layer(d, offset=(1, 1), shape=(2, 3), scale=1).tolist()
    [[0, 8, 0], [1, 0, 0]]
    """
    r0, c0 = offset
    rows, cols = shape
    part = np.zeros((rows, cols), np.float32)
    crop = density[r0:r0 + rows, c0:c0 + cols]
    part[:crop.shape[0], :crop.shape[1]] = crop
    index = np.where(part > 0, 1 + np.minimum(7, (part * 8).astype(np.int64)), 0)
    return np.repeat(np.repeat(index.astype(np.uint8), scale, axis=0), scale, axis=1)


def _missing_layer(missing: list[dict], view: tuple[int, int, int, int]
                   ) -> tuple[str, str, str]:
    """``(svg, label, legend)`` of the missing-walls layer: dashed boxes in the map's own
    cells (the flags of :func:`slamq.metrics.agreement.missing_walls` are on the map's
    image grid, row 0 at the top, as the defects' boxes), each grown by a little so that
    the stretch inside stays visible, and kept, with its label, inside the picture
    (``view``: its first column and row, columns and rows); the legend says what they are
    and that the verdict does not read them."""
    c0, r0, cols, rows = view
    n = len(missing)
    size = max(rows, cols) / 45.0
    pad, stroke = size / 5, size / 7
    boxes = []
    for i, d in enumerate(missing):
        a, b, c, e = (float(v) for v in d["bbox"])
        metres = float(d.get("score", math.nan))
        text = f"{i + 1} missing wall" + (f" ({metres:.1f} m)" if math.isfinite(metres)
                                          else "")
        x1, y1 = max(a - pad, c0 + stroke / 2), max(b - pad, r0 + stroke / 2)
        x2 = max(min(c + pad, c0 + cols - stroke / 2), x1 + 0.5)
        y2 = max(min(e + pad, r0 + rows - stroke / 2), y1 + 0.5)
        # the label above the box, else below it, else inside; right-aligned near the edge
        wide = 0.6 * size * len(text)
        anchor, tx = ("start", x1) if x1 + wide <= c0 + cols else ("end", x2)
        ty = (y1 - size / 4 if y1 - size >= r0 else
              y2 + size if y2 + size * 1.1 <= r0 + rows else y1 + size)
        boxes.append(
            f"<g class=\"missing\" data-bbox=\"{a:g} {b:g} {c:g} {e:g}\"><title>"
            f"{_e(d.get('note', ''))}</title><rect x=\"{x1:.6g}\" y=\"{y1:.6g}\" "
            f"width=\"{x2 - x1:.6g}\" height=\"{y2 - y1:.6g}\" fill=\"none\" "
            f"stroke=\"{_MISSING_COLOUR}\" stroke-width=\"{stroke:.4g}\" "
            f"stroke-dasharray=\"{size / 3:.4g} {size / 5:.4g}\"/>"
            f"<text x=\"{tx:.6g}\" y=\"{ty:.6g}\" text-anchor=\"{anchor}\" "
            f"font-size=\"{size:.4g}\" fill=\"{_MISSING_COLOUR}\" stroke=\"#fff\" "
            f"stroke-width=\"{size / 10:.4g}\" paint-order=\"stroke\">{_e(text)}</text></g>")
    svg = (f"<svg class=\"layer layer-missing\" viewBox=\"{c0} {r0} {cols} {rows}\" "
           f"preserveAspectRatio=\"none\">{''.join(boxes)}</svg>") if boxes else ""
    label = (f"<i class=\"dash\"></i> {n} missing wall{'' if n == 1 else 's'} "
             "(informational): walls most other maps of the sequence have where this map "
             "sees free space &mdash; not used by the verdict")
    rows_html = "".join(
        f"<li>{i + 1}: cells [{_e(', '.join(format_value(v) for v in d['bbox']))}]; "
        f"{_e(d.get('note', ''))}</li>" for i, d in enumerate(missing))
    legend = (
        "<div class=\"legend missing-legend\"><p><i class=\"dash\"></i> <b>Missing walls"
        "</b> (informational): the longest stretch, from "
        f"{MISSING_MIN_LENGTH:g} m, of walls that more than half of the other maps of the "
        "sequence have (laid over this map as for the agreement) where this map sees free "
        "space: a missing wall, or a leak through a gap the others close. Not used by the "
        "verdict: doors open in one run and closed in another, and noise, flag many good "
        "maps too (docs/validity.md, \"Missing walls against the other maps\").</p>"
        + (f"<ul>{rows_html}</ul>" if rows_html else "") + "</div>")
    return svg, label, legend


def _trajectory_section(rec: dict, evidence: TrajectoryEvidence | Exception | None, grid: Any,
                        out: Path, mp: MapPage) -> str:
    if not usable(rec.get("trajectory")) or evidence is None:
        return ""
    from slamq.report.trajectory import draw_trajectory, time_plot_path

    png = f"img/{mp.slug}_traj.png"
    try:
        if isinstance(evidence, Exception):
            raise evidence
        caption = draw_trajectory(evidence, grid, out / png)
    except Exception as exc:  # noqa: BLE001 - a bad trajectory is a note, never a crash
        return f"<h2>Trajectory</h2><p class=\"warn\">not drawn: {_e(exc)}</p>"
    over_time = time_plot_path(Path(png))
    time_img = (f"<p><img src=\"../{over_time.as_posix()}\" alt=\"ATE over time\"></p>"
                if (out / over_time).is_file() else "")
    return (f"<h2>Trajectory over the map</h2><p>{_e(caption)}</p>"
            f"<p class=\"big\"><img src=\"../{png}\" alt=\"trajectory coloured by ATE\"></p>"
            + time_img)


def _building_section(building: tuple[str, Timeline | None] | Exception | None, out: Path,
                      mp: MapPage) -> str:
    from slamq.report.timeline import write_timeline_gif

    if building is None:
        return ""
    try:
        if isinstance(building, Exception):
            raise building
        what, timeline = building
        if timeline is None:
            return ""
        gif = f"img/{mp.slug}_build.gif"
        write_timeline_gif(timeline, out / gif)
    except (SlamqError, OSError, ValueError) as exc:
        return f"<h2>Map building</h2><p class=\"warn\">no animation: {_e(exc)}</p>"
    mp.gif = gif
    return (f"<h2>Map building</h2><p>{_e(what)}; the metrics of each snapshot on the "
            "right, the red line marks the current one.</p>"
            f"<p class=\"big\"><img src=\"../{gif}\" alt=\"map being built\"></p>")

