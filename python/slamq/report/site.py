"""Build the static report site: ``index.html``, one detail page per map, images beside.

Everything the pages use is in the output folder (PNG/GIF files and inline CSS); nothing is
fetched from the network and no script is needed, so the site opens from ``file://``.

The gallery shows each map itself (a thumbnail of the plain map). A map's detail page draws
what was counted on it as layers over the plain map, each switched on and off by a checkbox
(CSS only): the counted corners, the counted enclosed areas, the comparison with the
sequence's ground-truth map (when there is one), the map's defects and, in a sequence
judged without ground truth, its missing walls against the other maps of the sequence
(:func:`slamq.metrics.agreement.missing_walls` on the agreement the verdict computed: walls
most other maps have where this map sees free space; informational, off at first, not used
by the verdict, docs/validity.md "Missing walls against the other maps"). Defects are boxes
``{"kind": str, "bbox": [col0, row0, col1, row1], "note": str}`` in the map's cells
(row 0 at the top, as the map's image; ``col1`` and ``row1`` exclusive, as
``values[row0:row1, col0:col1]``), taken from the record's ``defects`` field (a JSON list,
or a list) and from ``build_report(..., defects_for=f)``, which calls ``f(map)`` with each
loaded :class:`~slamq.OccupancyMap` (``map.source`` is its path); by default ``f`` runs
:func:`slamq.metrics.defects.detect_defects`, the detectors the verdict reads.
"""

from __future__ import annotations

import datetime as _dt
import html
import json
import math
import re
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from slamq.errors import SlamqError
from slamq.metrics.agreement import MISSING_MIN_LENGTH
from slamq.report.data import ResultsLike, evaluate_map, load_results, params_of, usable
from slamq.report.evidence import sequence_evidence
from slamq.report.ranking import (
    CANONICAL,
    METRICS,
    SequenceRanking,
    format_mean_std,
    format_value,
    rank_sequence,
    summarize,
)
from slamq.report.verdict import basis_name, needs_evidence, verdict_sentence, write_verdicts
from slamq.results.columns import GROUND_TRUTH_ALGORITHMS
from slamq.results.summary import spreadsheet_safe

__all__ = ["build_report"]

_CSS = """
body{font:15px/1.45 system-ui,-apple-system,'Segoe UI',Roboto,sans-serif;margin:0;color:#222;
 background:#fafafa}
main{max-width:1180px;margin:0 auto;padding:18px 22px 60px}
h1{font-size:1.6em;margin:.2em 0}
h2{font-size:1.3em;margin:1.6em 0 .4em;border-bottom:2px solid #ddd;padding-bottom:.2em}
h3{font-size:1.05em;margin:1.1em 0 .4em}
.sub{color:#666;margin:0 0 1em}
.verdict{background:#eef6ee;border:1px solid #b6d7b6;border-radius:8px;padding:10px 16px}
.verdict li{margin:.3em 0}
.warn{background:#fff5e0;border:1px solid #e8c77a;border-radius:6px;padding:6px 10px;
 margin:.5em 0}
table{border-collapse:collapse;background:#fff;margin:.4em 0}
th,td{border:1px solid #ddd;padding:4px 9px;text-align:left}
th{background:#f0f0f0;font-weight:600}
th.basis{background:#d8ead8}
td.num{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap}
td.best{background:#d8f0d8;font-weight:700}
td.best::after{content:" \\2605";color:#2a7a2a}
tr.winner td.alg{font-weight:700}
.gallery{display:flex;flex-wrap:wrap;gap:14px}
.card{background:#fff;border:1px solid #ddd;border-radius:8px;padding:8px;width:max-content}
.card h4{margin:0 0 6px;font-size:.95em}
.pair{display:flex;gap:8px}
figure{margin:0}
figure img{display:block;border:1px solid #ccc;background:#888}
figcaption{font-size:.82em;color:#444;max-width:230px}
.plots img{max-width:100%;border:1px solid #ddd;background:#fff;margin:6px 0}
details{margin:.5em 0}
summary{cursor:pointer;color:#0a58ca}
.legend span{display:inline-block;margin-right:14px}
.ring{display:inline-block;width:11px;height:11px;border:2px solid red;border-radius:50%;
 vertical-align:middle}
.swatch{display:inline-block;width:13px;height:13px;background:#1f77b4;opacity:.75;
 vertical-align:middle}
.big img{max-width:100%;height:auto;border:1px solid #ccc}
.thumb{position:relative;display:inline-block}
.badge{display:inline-block;font-size:.75em;font-weight:600;border-radius:9px;padding:1px 7px;
 background:#2a7a2a;color:#fff;vertical-align:middle}
.thumb .badge{position:absolute;right:4px;top:4px;background:#b02a2a}
.layers{margin-top:.2em}
.layers label{margin:0 18px 0 0;cursor:pointer;white-space:nowrap;line-height:2}
.layers input{vertical-align:middle;margin:0 4px 0 0}
.layers label:has(input:disabled){color:#999;cursor:default}
.layers label .swatch,.layers label .ring{margin-right:2px}
.stack{position:relative;display:block;width:fit-content;max-width:100%;line-height:0;
 margin-top:6px;outline:1px solid #ccc}
.stack a{display:block}
.stack img.base{display:block;max-width:100%;height:auto}
.stack .layer{position:absolute;left:0;top:0;width:100%;height:100%;pointer-events:none}
.stack svg.layer text{font-family:system-ui,sans-serif;font-weight:700}
.layers:has(#show-corners:not(:checked)) .layer-corners,
.layers:has(#show-regions:not(:checked)) .layer-regions,
.layers:has(#show-gt:not(:checked)) .layer-gt,
.layers:has(#show-defects:not(:checked)) .layer-defects,
.layers:has(#show-missing:not(:checked)) .layer-missing{display:none}
table.defects td{font-size:.9em}
.layers label[for=show-missing]{white-space:normal;display:inline-block}
.dash{display:inline-block;width:13px;height:9px;border:2px dashed #e00000;
 vertical-align:middle;margin-right:2px}
.top{display:flex;gap:24px;align-items:flex-start;flex-wrap:wrap}
.mapcol{flex:1;min-width:420px}
.files{font-size:.85em;padding-left:1.2em;word-break:break-all}
footer{color:#777;font-size:.85em;margin-top:3em}
a{color:#0a58ca}
"""

_WINNER = ' class="winner"'
_BEST = " best"
_METRIC_HELP = {m.key: m for m in (*METRICS, CANONICAL)}
_SLUG = re.compile(r"[^A-Za-z0-9_.-]+")


def _e(x: Any) -> str:
    return html.escape(str(x), quote=True)


def _slug(x: Any) -> str:
    return _SLUG.sub("-", str(x)).strip("-")[:60] or "x"


def _page(title: str, body: str, *, root: str = "") -> str:
    return (
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
        "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">"
        "<link rel=\"icon\" href=\"data:,\">"
        f"<title>{_e(title)}</title><style>{_CSS}</style></head>"
        f"<body><main>{body}</main></body></html>\n"
    )


@dataclass
class _MapPage:
    """One map's detail page and its pictures (paths relative to the site root)."""

    index: int
    record: dict
    slug: str
    page: str = ""
    thumb: str = ""
    full: str = ""
    gif: str = ""
    notes: list[str] = field(default_factory=list)
    defects: list[dict] = field(default_factory=list)
    #: Missing walls against the other maps of the sequence (None: the map took no part in
    #: an agreement, e.g. its sequence has ground truth).
    missing: list[dict] | None = None


def build_report(
    results: ResultsLike,
    out_dir: Any,
    *,
    title: str = "slamq evaluation report",
    details: str = "all",
    gifs: bool = True,
    trajectories: bool = True,
    progress: Callable[[int, int], None] | None = None,
    defects_for: Callable[[Any], list[dict]] | None = None,
    reuse: bool = False,
) -> Path:
    """Write the evaluation report for a results file and return the path of index.html.

    Parameters
    ----------
    results : path, DataFrame or list of dict
        Batch results (``slamq batch`` output: ``.jsonl``/``.parquet``), or records with
        ``map``, ``algorithm``, ``sequence``, ``run`` and the metric columns.
    out_dir : path
        Folder to write (created; existing report files are overwritten).
    title : str
        Page title.
    details : {"all", "gallery"}
        Detail pages for every successful map, or only for the gallery's runs (each
        algorithm's two ends of the deciding column; for very large batches: each detail
        page loads and re-draws its map).
    gifs : bool
        Animate map building when a run folder holds ``map_0001.pgm``-style snapshots.
    trajectories : bool
        Draw each run's trajectory over its map, coloured by ATE, when it has one.
    progress : callable, optional
        ``progress(done, total)`` after each detail page (the slow part).
    defects_for : callable, optional
        ``defects_for(map)`` with each loaded map (an :class:`~slamq.OccupancyMap`;
        ``map.source`` is its path) returns a list of defects, ``{"kind": str, "bbox":
        [col0, row0, col1, row1], "note": str}`` in the map's cells (``col1``, ``row1``
        exclusive); drawn as a layer of the map's detail page, after the defects of the
        record's own ``defects`` field (a JSON string or a list). Default: the defect
        detectors the verdict reads (:func:`slamq.metrics.defects.detect_defects`).
        (The missing walls of a map against the other maps of its sequence are a layer of
        their own, drawn in the sequences judged without ground truth.)
    reuse : bool
        Keep the detail pages (and their pictures) of an earlier build into ``out_dir``
        whose inputs did not change: the record, the page's name, ``gifs`` and
        ``trajectories``, the content of the map, trajectory, ground truth and snapshots
        the page draws, and slamq's version (kept in ``out_dir/.pages.json``, which also
        says how many pages were ``drawn`` and ``reused``). The index page is always
        written.

    Returns
    -------
    pathlib.Path
        ``out_dir / "index.html"``.

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib
    >>> from PIL import Image
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> img = np.full((30, 30), 254, np.uint8); img[8:22, 8:22] = 0
    >>> Image.fromarray(img).save(d / "a.pgm")
    >>> recs = [{"map": str(d / "a.pgm"), "algorithm": "a", "sequence": "s", "run": 0,
    ...          "occupied_fraction": 0.2, "corners": 4, "enclosed_areas": 0,
    ...          "enclosed_unknown_value": 0}]
    >>> build_report(recs, d / "site").name
    'index.html'
    """
    if defects_for is None:
        defects_for = _detected_defects
    if details not in ("all", "gallery"):
        raise SlamqError(f"details must be 'all' or 'gallery', got {details!r}")
    frame = load_results(results)
    out = Path(out_dir)
    (out / "img").mkdir(parents=True, exist_ok=True)
    (out / "maps").mkdir(parents=True, exist_ok=True)

    failed = frame[frame["error"].map(usable)]
    ok = frame[~frame["error"].map(usable)].copy()
    summary = summarize(ok)
    sequences = sorted(ok["sequence"].unique()) if len(ok) else []
    evidence = {s: sequence_evidence(ok, s) for s in sequences if needs_evidence(summary, s)}
    verdicts = {v["sequence"]: v for v in write_verdicts(summary, sequences, out, evidence)}
    _add_agreement(summary, evidence)
    rankings = {s: rank_sequence(summary, s, verdicts[s]) for s in sequences}

    pages: dict[int, _MapPage] = {}
    gallery: dict[tuple[str, str], list[int]] = {}
    for seq in sequences:
        sub = ok[ok["sequence"] == seq]
        for alg, group in sub.groupby("algorithm", sort=True):
            gallery[(seq, str(alg))] = _best_worst(group, verdicts[seq]["basis"])
    wanted = set(ok.index) if details == "all" else {i for v in gallery.values() for i in v}
    for i in sorted(wanted):
        rec = ok.loc[i].to_dict()
        slug = f"{i:04d}-{_slug(rec['sequence'])}-{_slug(rec['algorithm'])}-{_slug(rec['run'])}"
        pages[i] = _MapPage(i, rec, slug, page=f"maps/{slug}.html")
        ev = evidence.get(rec["sequence"])
        if ev is not None and usable(rec.get("map")):
            pages[i].missing = ev.get("missing_walls", {}).get(str(rec["map"]))
    kept = _read_page_cache(out) if reuse else {}
    fresh: dict[str, dict[str, Any]] = {}
    for done, mp in enumerate(pages.values(), 1):
        digest = _page_digest(mp, gifs=gifs, trajectories=trajectories) if reuse else ""
        old = kept.get(mp.page)
        if old is not None and old.get("digest") == digest and all(
                (out / f).is_file() for f in (mp.page, *old.get("files", []))):
            mp.thumb, mp.full, mp.gif = old["thumb"], old["full"], old["gif"]
            mp.notes = list(old["notes"])
        else:
            _detail_page(mp, out, gifs=gifs, trajectories=trajectories,
                         defects_for=defects_for)
            old = None
        if reuse:
            fresh[mp.page] = {"digest": digest, "thumb": mp.thumb, "full": mp.full,
                              "gif": mp.gif, "notes": mp.notes, "reused": old is not None,
                              "files": [f for f in (mp.thumb, mp.full, mp.gif) if f]}
        if progress is not None:
            progress(done, len(pages))
    if reuse:
        _write_page_cache(out, fresh)

    plots = _plots(ok, out, sequences)
    body = _index_body(title, frame, ok, failed, summary, sequences, rankings, verdicts,
                       gallery, pages, plots, _mixed_settings(frame))
    index = out / "index.html"
    index.write_text(_page(title, body), encoding="utf-8")
    write_tables(summary, out)
    spreadsheet_safe(summary.reset_index()).to_csv(out / "summary.csv", index=False)
    return index


_PAGE_CACHE = ".pages.json"


def _read_page_cache(out: Path) -> dict[str, dict[str, Any]]:
    import json

    try:
        data = json.loads((out / _PAGE_CACHE).read_text())
        pages = data["pages"]
    except (OSError, ValueError, KeyError, TypeError):
        return {}
    return pages if isinstance(pages, dict) else {}


def _write_page_cache(out: Path, pages: dict[str, dict[str, Any]]) -> None:
    import json
    import os

    reused = sum(1 for p in pages.values() if p["reused"])
    data = {"drawn": len(pages) - reused, "reused": reused, "pages": pages}
    tmp = out / (_PAGE_CACHE + ".tmp")
    tmp.write_text(json.dumps(data, indent=1, default=str))
    os.replace(tmp, out / _PAGE_CACHE)


def _page_digest(mp: _MapPage, *, gifs: bool, trajectories: bool) -> str:
    """Stamp of everything a detail page is drawn from (see ``reuse`` of
    :func:`build_report`)."""
    import hashlib
    import json

    from slamq.batch.records import content_hash
    from slamq.sources.snapshots import find_snapshots
    from slamq.version import __version__

    def map_digest(p: Any) -> str | None:
        try:
            return content_hash(p) if usable(p) else None
        except (OSError, SlamqError):
            return None

    def file_digest(p: Any) -> str | None:
        if not usable(p):
            return None
        try:
            return hashlib.sha1(Path(p).read_bytes(), usedforsecurity=False).hexdigest()
        except OSError:
            return None

    rec = mp.record
    snaps: list[Any] = []
    if gifs and usable(rec.get("map")):
        snaps = [[q.name, map_digest(q)] for q in find_snapshots(Path(rec["map"]).parent)]
    blob = json.dumps(
        {"record": rec, "slug": mp.slug, "page": mp.page, "gifs": gifs,
         "trajectories": trajectories, "version": __version__, "missing": mp.missing,
         "map": map_digest(rec.get("map")), "gt_map": map_digest(rec.get("gt_map")),
         "trajectory": file_digest(rec.get("trajectory")),
         "groundtruth": file_digest(rec.get("groundtruth")), "snapshots": snaps},
        sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()[:32]


def _mixed_settings(frame: pd.DataFrame) -> str:
    """A warning paragraph when the records were made with different settings, else ""."""
    if "config" not in frame:
        return ""
    from slamq.results.columns import settings_difference

    mixed = settings_difference(frame["config"])
    if not mixed:
        return ""
    return (f"<p class=\"warn\" id=\"mixed-settings\">These results were computed with "
            f"different settings ({_e(mixed)}): the tables and plots mix them. Evaluate every "
            "map again with one setting, or write the batch to another results file.</p>")


#: Columns a gallery orders an algorithm's runs by: the verdict's basis first, then these.
_RUN_ORDER = ("ate_rmse", "gt_f1", "corners_canonical", "corners")


def _run_key(group: pd.DataFrame, basis: Iterable[str] = ()) -> str | None:
    """The column the runs of ``group`` are ordered by: the verdict's basis when the runs
    have it, else the first of :data:`_RUN_ORDER` they have."""
    for key in [*basis, *_RUN_ORDER]:
        if key in group and pd.to_numeric(group[key], errors="coerce").notna().any():
            return key
    return None


def _best_worst(group: pd.DataFrame, basis: Iterable[str] = ()) -> list[int]:
    """Indices of the best and the worst run by the verdict's basis column (one index when
    they are the same run); runs without the figure come last."""
    key = _run_key(group, basis)
    if key is None:
        order = sorted(group.index, key=lambda i: str(group.loc[i, "run"]))
    else:
        higher = _METRIC_HELP[key].higher if key in _METRIC_HELP else False
        v = pd.to_numeric(group[key], errors="coerce")
        order = sorted(group.index, key=lambda i: (
            math.isnan(v[i]), (-v[i] if higher else v[i]) if not math.isnan(v[i]) else 0.0,
            str(group.loc[i, "run"])))
    return [order[0]] if len(order) == 1 else [order[0], order[-1]]


# ----------------------------------------------------------------------------- detail pages


def _detail_page(mp: _MapPage, out: Path, *, gifs: bool, trajectories: bool,
                 defects_for: Callable[[Any], list[dict]] | None = None) -> None:
    from slamq.report.overlays import draw_overlay
    from slamq.report.plots import curve_figure
    from slamq.sources import load_map

    rec = mp.record
    sections: list[str] = []
    grid = None
    quality = None
    try:
        grid = load_map(rec["map"])
        params = params_of(rec)
        quality = evaluate_map(grid, params, curve=True)
    except (SlamqError, OSError, ValueError) as exc:
        mp.notes.append(f"map not drawn: {exc}")
    if grid is not None and quality is not None:
        u = int(rec["enclosed_unknown_value"]) if usable(rec.get("enclosed_unknown_value")) \
            else int(quality.enclosed_unknown_value)
        ov = draw_overlay(grid, u, params)
        mp.full = f"img/{mp.slug}.png"
        mp.thumb = f"img/{mp.slug}_thumb.png"
        ov.save(str(out / mp.full), which="plain")
        ov.save(str(out / mp.thumb), max_size=230, which="plain")
        for key, drawn in (("corners", ov.n_corners), ("enclosed_areas", ov.n_regions)):
            if usable(rec.get(key)) and int(rec[key]) != drawn:
                mp.notes.append(
                    f"the results file says {key} = {int(rec[key])}, the map as loaded now "
                    f"gives {drawn} (file changed, or other parameters?)")
        mp.defects = _defects(rec, grid, defects_for, mp.notes)
        gt = _compare_gt(rec, grid, mp)
        sections.append(_map_layers(mp, out, ov, u, grid, gt))
        curve_png = f"img/{mp.slug}_curve.png"
        curve_figure(list(quality.curve), list(params.sweep_values),
                     int(quality.enclosed_unknown_value), out / curve_png)
        sections.append(
            "<h2>Enclosed areas over the unknown value</h2><p>The sweep of SPEC section 4 "
            "(paper III.C): unknown cells take every value u; the metric is the maximum.</p>"
            f"<p><img src=\"../{curve_png}\" alt=\"enclosed-area curve\"></p>")
        sections.append(_ground_truth_section(gt, out, mp))
        if trajectories:
            sections.append(_trajectory_section(rec, grid, out, mp))
        if gifs:
            sections.append(_building_section(rec, out, mp, params))
    rows = "".join(
        f"<tr><th>{_e(k)}</th><td class=\"num\">{_e(_fmt_cell(rec.get(k)))}</td></tr>"
        for k in _DETAIL_KEYS if k in rec and usable(rec.get(k)))
    files = "".join(
        f"<li>{_e(k)}: <code>{_e(rec.get(k))}</code></li>"
        for k in _FILE_KEYS if k in rec and usable(rec.get(k)))
    notes = "".join(f"<p class=\"warn\">{_e(n)}</p>" for n in mp.notes)
    head = (f"<p><a href=\"../index.html\">&larr; back to the report</a></p>"
            f"<h1>{_e(rec['algorithm'])} on {_e(rec['sequence'])}, run {_e(rec['run'])}</h1>"
            f"<ul class=\"sub files\">{files}</ul>{notes}")
    numbers = f"<div><h2>Numbers</h2><table class=\"numbers\">{rows}</table></div>"
    first = sections[0] if sections else ""
    rest = "".join(s for s in sections[1:] if s)
    (out / mp.page).write_text(
        _page(f"{rec['algorithm']} / {rec['sequence']} / run {rec['run']}",
              head + f"<div class=\"top\">{numbers}{first}</div>" + rest), encoding="utf-8")


_DETAIL_KEYS = (
    "ate_rmse", "ate_mean", "ate_median", "ate_std", "ate_min", "ate_max", "ate_n",
    "gt_precision", "gt_recall", "gt_f1", "gt_iou", "gt_ne", "gt_reverse", "gt_chamfer",
    "gt_coverage", "gt_dx", "gt_dy", "gt_dyaw", "gt_icp_rms", "gt_truncated", "gt_outside",
    "occupied_fraction", "corners", "enclosed_areas", "enclosed_unknown_value",
    "proportion", "threshold", "occupied", "free", "unknown", "known", "total",
    "height", "width", "seconds",
)
_FILE_KEYS = ("map", "trajectory", "groundtruth", "gt_map", "ate_error", "gt_error", "hash")


def _fmt_cell(x: Any) -> str:
    if isinstance(x, (int, np.integer)):
        return str(int(x))
    if isinstance(x, (float, np.floating)):
        return f"{float(x):.6g}"
    return str(x)


def _compare_gt(rec: dict, grid: Any, mp: _MapPage) -> tuple[Any, Any] | None:
    """``(comparison, ground-truth map)`` of the record's map against its sequence's
    ground-truth map with the batch's settings (docs/spec.md section 7), else None."""
    if not usable(rec.get("gt_map")) or usable(rec.get("gt_error")):
        return None
    from slamq.api import compare
    from slamq.sources import load_map

    cfg = _gt_config(rec.get("config"))
    try:
        gt = load_map(rec["gt_map"])
        c = compare(grid, gt, align=cfg[0], tolerance=cfg[1], max_distance=cfg[2],
                    cells=True)
    except (SlamqError, OSError, ValueError) as exc:
        mp.notes.append(f"ground-truth overlay not drawn: {exc}")
        return None
    return c, gt


_GT_KINDS = (("matched", "ground-truth walls the map has"),
             ("missing", "ground-truth walls the map lacks"),
             ("ghost", "walls only the map has"))


def _gt_swatches() -> str:
    from slamq.report.comparison import COMPARISON_COLOURS

    return "".join(
        f"<span><i class=\"swatch\" style=\"background:rgb{COMPARISON_COLOURS[k]}\"></i> "
        f"{label}</span>" for k, label in _GT_KINDS)


def _ground_truth_section(gt: tuple[Any, Any] | None, out: Path, mp: _MapPage) -> str:
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


def _add_agreement(summary: pd.DataFrame, evidence: dict[str, dict[str, Any]]) -> None:
    """The agreement figure of each algorithm as a summary column (``agreement_mean``,
    ``_std``, ``_n``), so that the table shows what the verdict rested on."""
    if not evidence or not len(summary):
        return
    summary["agreement_mean"] = math.nan
    summary["agreement_std"] = math.nan
    summary["agreement_n"] = 0
    for seq, ev in evidence.items():
        for alg, e in ev["algorithms"].items():
            if (seq, alg) in summary.index and math.isfinite(e["support"]):
                summary.loc[(seq, alg), ["agreement_mean", "agreement_n"]] = (
                    e["support"], e["runs"])


def _detected_defects(grid: Any) -> list[dict]:
    """The defect detectors' flags on a map, as the detail page draws them."""
    from slamq.metrics.defects import detect_defects  # on first use

    return [d.to_dict() for d in detect_defects(grid)]


def _defects(rec: dict, grid: Any, defects_for: Callable[[Any], list[dict]] | None,
             notes: list[str]) -> list[dict]:
    """The map's defects: the record's ``defects`` field (a JSON string or a list), then
    ``defects_for(grid)``; a malformed entry becomes a note on the page."""
    found: list[Any] = []
    raw = rec.get("defects")
    if isinstance(raw, str) and raw.strip():
        try:
            raw = json.loads(raw)
        except ValueError as exc:
            notes.append(f"defects field is not JSON: {exc}")
            raw = None
    if isinstance(raw, (list, tuple, np.ndarray)):
        found.extend(raw)
    elif usable(raw) and not isinstance(raw, str):
        notes.append(f"defects field is not a list: {str(raw)[:80]}")
    if defects_for is not None:
        try:
            found.extend(defects_for(grid) or [])
        except Exception as exc:  # noqa: BLE001 - a failing detector is a note, never a crash
            notes.append(f"defects_for failed: {type(exc).__name__}: {exc}")
    good = []
    for i, d in enumerate(found):
        try:
            bbox = [float(v) for v in d["bbox"]]
            if len(bbox) != 4 or not all(map(math.isfinite, bbox)):
                raise ValueError("bbox needs 4 finite numbers")
            good.append({"kind": str(d.get("kind", "defect")), "bbox": bbox,
                         "note": str(d.get("note", ""))})
        except (TypeError, KeyError, ValueError, AttributeError) as exc:
            notes.append(f"defect {i} ignored ({exc}): {str(d)[:80]}")
    return good


_DEFECT_COLOURS = ("#ff00ff", "#ff8800", "#00c8ff", "#ffd400", "#8a2be2", "#00b050")


def _map_layers(mp: _MapPage, out: Path, ov: Any, u: int, grid: Any,
                gt: tuple[Any, Any] | None) -> str:
    """The map with its layers (corners, enclosed areas, ground truth, defects, missing
    walls), each shown or hidden by a checkbox (CSS only: ``.layers:has(#show-X:not(:checked))
    .layer-X``)."""
    from PIL import Image

    rows, cols = ov.cells
    r0, c0 = ov.offset
    h, w = ov.plain.shape[:2]
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
        Image.fromarray(ov.regions).save(out / png)
        layers.append(f"<img class=\"layer layer-regions\" src=\"../{png}\" alt=\"\">")
    toggle("regions", f"<i class=\"swatch\"></i> {ov.n_regions} enclosed areas "
           f"(unknown cells set to u = {u})", True, ov.n_regions > 0)
    radius = max(1.5, max(rows, cols) / 110.0)
    rings = "".join(f"<circle cx=\"{cc + 0.5:.6g}\" cy=\"{rr + 0.5:.6g}\" r=\"{radius:.4g}\"/>"
                    for rr, cc in ov.corners)
    layers.append(
        f"<svg class=\"layer layer-corners\" viewBox=\"{view}\" preserveAspectRatio=\"none\">"
        f"<g fill=\"none\" stroke=\"red\" stroke-width=\"{radius / 3:.4g}\">{rings}</g></svg>")
    toggle("corners", f"<i class=\"ring\"></i> {ov.n_corners} corners", True,
           ov.n_corners > 0)
    if gt is not None:
        from slamq.report.comparison import ground_truth_layer

        png = f"img/{mp.slug}_gtlayer.png"
        Image.fromarray(ground_truth_layer(gt[0], grid, gt[1], offset=(r0, c0),
                                           shape=(rows, cols), scale=ov.scale)).save(out / png)
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
    toggle("defects", f"{len(mp.defects)} defect{'' if len(mp.defects) == 1 else 's'}", True,
           bool(mp.defects))
    legend = (f"<p class=\"legend gt-legend\">ground-truth layer: {_gt_swatches()}</p>"
              if gt is not None else "")
    if mp.missing is not None:
        layer, label, legend_missing = _missing_layer(mp.missing, (c0, r0, cols, rows))
        if layer:
            layers.append(layer)
        toggle("missing", label, False, bool(mp.missing))
        legend += legend_missing
    table = ""
    if mp.defects:
        table = ("<table class=\"defects\"><tr><th>#</th><th>kind</th><th>cells [col0, row0,"
                 " col1, row1]</th><th>note</th></tr>" + "".join(
                     f"<tr><td>{i + 1}</td><td>{_e(d['kind'])}</td><td>"
                     f"{_e(', '.join(format_value(v) for v in d['bbox']))}</td>"
                     f"<td>{_e(d['note'])}</td></tr>" for i, d in enumerate(mp.defects))
                 + "</table>")
    return (
        "<div class=\"mapcol\"><h2>The map</h2><p class=\"sub\">unknown cells grey, occupied "
        "black, free white; north up. Layers:</p><div class=\"layers\">"
        f"<p class=\"toggles\">{' '.join(toggles)}</p><div class=\"stack\">"
        f"<a href=\"../{mp.full}\"><img class=\"base\" src=\"../{mp.full}\" width=\"{w}\" "
        f"height=\"{h}\" alt=\"the map\"></a>"
        f"{''.join(layers)}</div></div>{legend}{table}</div>")


_MISSING_COLOUR = "#e00000"


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


def _gt_config(config: Any) -> tuple[str, float | None, float | None]:
    """``(align, tolerance, max_distance)`` of the record's comparison settings."""
    import json

    try:
        gt = json.loads(config)["gt"]
        return str(gt[0]), gt[1], gt[2]
    except (TypeError, ValueError, KeyError, IndexError):
        from slamq.params import SETTINGS

        return SETTINGS.compare_align.default, None, None


def _trajectory_section(rec: dict, grid: Any, out: Path, mp: _MapPage) -> str:
    if not usable(rec.get("trajectory")):
        return ""
    from slamq.report.trajectory import draw_trajectory, time_plot_path

    png = f"img/{mp.slug}_traj.png"
    try:
        caption = draw_trajectory(rec, grid, out / png)
    except Exception as exc:  # noqa: BLE001 - a bad trajectory is a note, never a crash
        return f"<h2>Trajectory</h2><p class=\"warn\">not drawn: {_e(exc)}</p>"
    over_time = time_plot_path(Path(png))
    time_img = (f"<p><img src=\"../{over_time.as_posix()}\" alt=\"ATE over time\"></p>"
                if (out / over_time).is_file() else "")
    return (f"<h2>Trajectory over the map</h2><p>{_e(caption)}</p>"
            f"<p class=\"big\"><img src=\"../{png}\" alt=\"trajectory coloured by ATE\"></p>"
            + time_img)


def _building_section(rec: dict, out: Path, mp: _MapPage, params: Any) -> str:
    from slamq.report.timeline import bag_maps, build_timeline, write_timeline_gif
    from slamq.sources.snapshots import find_snapshots

    path = Path(rec["map"])
    sources: list[Any] = []
    what = ""
    try:
        if path.suffix.lower() in (".bag", ".mcap", ".db3") or (path / "metadata.yaml").is_file():
            sources = bag_maps(path) or []
            what = f"every /map message of {path.name}"
        else:
            sources = find_snapshots(path.parent)
            what = f"{len(sources)} snapshots in {path.parent.name}/"
        if len(sources) < 2:
            return ""
        timeline = build_timeline(sources, params)
        gif = f"img/{mp.slug}_build.gif"
        write_timeline_gif(timeline, out / gif)
    except (SlamqError, OSError, ValueError) as exc:
        return f"<h2>Map building</h2><p class=\"warn\">no animation: {_e(exc)}</p>"
    mp.gif = gif
    return (f"<h2>Map building</h2><p>{_e(what)}; the metrics of each snapshot on the "
            "right, the red line marks the current one.</p>"
            f"<p class=\"big\"><img src=\"../{gif}\" alt=\"map being built\"></p>")


# ----------------------------------------------------------------------------- index page


def _plots(ok: pd.DataFrame, out: Path, sequences: list[str]) -> list[tuple[str, str]]:
    from slamq.report.plots import algorithm_colours, metric_figure

    # a reference (ground-truth) map is shown beside the ranking, never plotted as an
    # algorithm among the others
    ok = ok[~ok["algorithm"].astype(str).str.lower().isin(GROUND_TRUTH_ALGORITHMS)]
    if ok.empty:
        return []
    colours = algorithm_colours(ok["algorithm"].astype(str))
    made = []
    for m in METRICS:
        if m.key not in ok or not np.isfinite(pd.to_numeric(ok[m.key], errors="coerce")).any():
            continue
        png = f"img/plot_{m.key}.png"
        metric_figure(ok, m, out / png, sequences=sequences, colours=colours)
        made.append((m.key, png))
    return made


def _index_body(
    title: str,
    frame: pd.DataFrame,
    ok: pd.DataFrame,
    failed: pd.DataFrame,
    summary: pd.DataFrame,
    sequences: list[str],
    rankings: dict[str, SequenceRanking],
    verdicts: dict[str, dict[str, Any]],
    gallery: dict[tuple[str, str], list[int]],
    pages: dict[int, _MapPage],
    plots: list[tuple[str, str]],
    warning: str = "",
) -> str:
    from slamq.version import __version__

    n_alg = ok["algorithm"].nunique() if len(ok) else 0
    parts = [
        f"<h1>{_e(title)}</h1>",
        f"<p class=\"sub\">{len(frame)} maps: {len(ok)} evaluated, {len(failed)} failed; "
        f"{len(sequences)} sequences, {n_alg} algorithms. Generated "
        f"{_dt.datetime.now().strftime('%Y-%m-%d %H:%M')} by slamq {__version__}.</p>",
        warning,
        "<section class=\"verdict\" id=\"verdict\"><b>In one sentence per sequence</b> "
        "(also in <a href=\"verdict.json\">verdict.json</a>; the tables below follow it and "
        "show every metric for reference)<ul>",
    ]
    for s in sequences:
        v = verdicts[s]
        sent = _e(verdict_sentence(v))
        head = _e(f"{s}:")
        if sent.startswith(head):
            sent = sent[len(head):]
        if v["best"]:
            sent = sent.replace(_e(v["best"]), f"<b>{_e(v['best'])}</b>", 1)
        notes = "".join(f"<br><small>{_e(w)}</small>" for w in v["warnings"])
        parts.append(f"<li><a href=\"#seq-{_slug(s)}\">{_e(s)}</a>:{sent}{notes}</li>")
    if not sequences:
        parts.append("<li>No map was evaluated successfully.</li>")
    parts.append("</ul></section>")
    parts.append(_validity_section(ok))
    parts.append(_how_to_read())
    for s in sequences:
        parts.append(_sequence_section(s, ok, summary, rankings[s], gallery, pages))
    if plots:
        parts.append("<h2 id=\"plots\">Plots</h2><p>Every run is a point; boxes show the "
                     "spread per algorithm; one panel per sequence. Lower is better on "
                     "every axis.</p><div class=\"plots\">")
        for key, png in plots:
            parts.append(f"<img src=\"{png}\" alt=\"{_e(_METRIC_HELP[key].label)} per run\">")
        parts.append("</div>")
    if len(failed):
        rows = "".join(f"<tr><td>{_e(r['map'])}</td><td>{_e(r['error'])}</td></tr>"
                       for _, r in failed.iterrows())
        parts.append(f"<h2 id=\"failed\">Failed maps ({len(failed)})</h2>"
                     f"<table><tr><th>map</th><th>error</th></tr>{rows}</table>")
    parts.append(
        "<footer>Metrics: Filatov, Filatov, Krinkin, Chen, Molodan, <i>2D SLAM Quality "
        "Evaluation Methods</i>, arXiv:1708.02354, as pinned down by slamq's spec (docs/spec.md). "
        "Means and sample standard deviations (n&minus;1) over runs; "
        "<a href=\"summary.csv\">summary.csv</a> holds them unrounded; the tables as "
        "<a href=\"tables.md\">Markdown</a> and <a href=\"tables.tex\">LaTeX</a>.</footer>")
    return "".join(parts)


def _validity_section(ok: pd.DataFrame) -> str:
    """How well each no-reference metric agreed with this report's own ground truth
    (slamq.results.validity, pooled over its sequences), and the figures measured once on
    slam_comparison_tools and the synthetic study (shipped with slamq)."""
    from slamq.results.validity import SHIPPED_CONCORDANCE, validate

    shipped = "".join(
        f"<tr><td>{_e(metric)}</td>" + "".join(f"<td>{v:.2f}</td>" for v in values) + "</tr>"
        for metric, values in SHIPPED_CONCORDANCE.items())
    parts = [
        "<section id=\"validity\"><h2>Which numbers to trust</h2>"
        "<p>Pairwise concordance of each map metric (0.5 = chance, 1 = always the same "
        "order), measured once: with the trajectory error on slam_comparison_tools (3 "
        "worlds x 5 algorithms), and with the damage in slamq's synthetic study (slamq.synth;"
        " for rotation the ideal is 0.5, no change). The verdict ranks by ground truth when "
        "there is any; else by how far the other maps of the sequence confirm each map, "
        "never naming a map they do not confirm or a defect detector flags, with corners "
        "only ordering the maps confirmed equally when they share one resolution and "
        "orientation; never by the others (docs/validity.md, \"The verdict "
        "without ground truth\").</p>"
        "<table class=\"validity shipped\"><tr><th>metric</th><th>vs ATE</th>"
        "<th>drift</th><th>wall doubling</th><th>rotation</th><th>specks</th></tr>"
        f"{shipped}</table>"]
    table = validate(ok, permutations=1000)
    pooled = table[table["sequence"] == "(pooled)"]
    if not pooled.empty:
        rows = "".join(
            f"<tr><td>{_e(r.metric)}</td><td>{_e(r.truth)}</td><td>{r.n}</td>"
            f"<td>{r.agreement:+.2f}</td><td>{r.concordance:.2f}</td>"
            f"<td>{'–' if r.p_value != r.p_value else f'{r.p_value:.3f}'}</td></tr>"
            for r in pooled.itertuples())
        parts.append(
            "<h3>Measured on these results</h3>"
            "<p>How well each map metric orders the maps as the ground truth does, pooled "
            "over the sequences with ground truth (agreement: Spearman, +1 = the same order;"
            " concordance: share of map pairs in the same order, 0.5 = chance; p: "
            "permutation test).</p>"
            "<table class=\"validity\"><tr><th>metric</th><th>ground truth</th><th>maps"
            "</th><th>agreement</th><th>concordance</th><th>p</th></tr>" + rows + "</table>")
    return "".join(parts) + "</section>"


def _how_to_read() -> str:
    items = "".join(
        f"<li><b>{_e(m.heading)}</b>: {m.direction} &mdash; {_e(m.why)}.</li>" for m in METRICS)
    return (
        "<details id=\"how\"><summary>How to read this page</summary><ul>" + items +
        "<li><b>Ranking</b>: each table is in the verdict's order (verdict.json): by ATE RMSE "
        "when the sequence has ground truth, else by GT F1, else by corners; the column that "
        "decides is marked <i>decides</i>. The other columns are shown for reference and "
        "decide nothing. &#9733; marks the best value per column. Algorithms without the "
        "deciding figure are listed last, unranked (&ndash;).</li><li>The map metrics "
        "compare maps of one sequence with similar coverage (paper III.A, III.B): a map that "
        "covers much less ground looks good on all three. Such maps are flagged.</li>"
        "<li>Gallery: each algorithm's runs at both ends of the deciding column, drawn plain."
        " Click a map for its detail page, where the counted corners, the counted enclosed "
        "areas, the comparison with a ground-truth map, any defects and (without ground "
        "truth) the walls the other maps have that the map lacks are layers to switch "
        "on and off.</li></ul></details>")


def _sequence_section(
    seq: str,
    ok: pd.DataFrame,
    summary: pd.DataFrame,
    ranking: SequenceRanking,
    gallery: dict[tuple[str, str], list[int]],
    pages: dict[int, _MapPage],
) -> str:
    block = summary.xs(seq, level="sequence")
    metrics = ranking.metrics
    basis = ranking.verdict.get("basis", [])
    decides = basis[0] if basis else None
    head = "".join(
        f"<th class=\"basis\">{_e(m.heading)}<br><small>decides</small></th>"
        if m.key == decides else f"<th>{_e(m.heading)}</th>" for m in metrics)
    head += "<th title=\"mean known area relative to the most complete map of the sequence\">"
    head += "known area</th>"
    rows = []
    place = 0
    for alg in ranking.order + ranking.ground_truths:
        row = block.loc[alg]
        reference = alg in ranking.ground_truths
        ranked = alg in ranking.ranked
        place += ranked
        cells = []
        for m in metrics:
            mean, std, n = row[f"{m.key}_mean"], row[f"{m.key}_std"], int(row[f"{m.key}_n"])
            best = (not reference and alg in ranking.best.get(m.key, [])
                    and len(ranking.ranks[m.key]) > 1)
            cells.append(
                f"<td class=\"num{_BEST if best else ''}\" data-metric=\"{m.key}\" "
                f"data-mean=\"{float(mean)!r}\" data-std=\"{float(std)!r}\" data-n=\"{n}\">"
                f"{_e(format_mean_std(mean, std))}</td>")
        cov = ranking.coverage.get(str(alg))
        cells.append(
            f"<td class=\"num{' warn' if alg in ranking.partial else ''}\" "
            f"data-known-share=\"{'' if cov is None else repr(cov)}\">"
            f"{'–' if cov is None else f'{100 * cov:.0f}%'}</td>")
        rank = "ref." if reference else str(place) if ranked else "–"
        title = (" title=\"reference map, not ranked\"" if reference else "" if ranked else
                 f" title=\"not ranked: no {_e(decides or 'figure to rank by')}\"")
        rows.append(
            f"<tr data-algorithm=\"{_e(alg)}\"{_WINNER if alg == ranking.winner else ''}>"
            f"<td class=\"num\"{title}>{rank}</td><td class=\"alg\">{_e(alg)}</td>"
            f"<td class=\"num\">{int(row['n'])}</td>{''.join(cells)}</tr>")
    parts = [
        f"<h2 id=\"seq-{_slug(seq)}\">{_e(seq)}</h2>",
        f"<p class=\"ranking-sentence\">{_e(ranking.sentence())}</p>",
    ]
    from slamq.results.summary import comparability_warnings

    mine = ok[ok["sequence"].astype(str) == str(seq)] if "sequence" in ok.columns else ok
    for msg in comparability_warnings(mine):
        parts.append(f"<p class=\"warn comparability\">{_e(msg.split(': ', 1)[-1])}</p>")
    for alg in ranking.partial:
        parts.append(
            f"<p class=\"warn\">{_e(alg)}'s maps know "
            f"{100 * ranking.coverage.get(alg, 0.0):.0f}% of the area of the most complete map "
            "of this sequence (under 80%): a partial map scores well on every map metric "
            "(paper III.A), so compare it with care; it is never named best.</p>")
    parts.append(
        f"<table class=\"ranking\" data-sequence=\"{_e(seq)}\"><tr><th>rank</th>"
        f"<th>algorithm</th><th>runs</th>{head}</tr>" + "".join(rows) + "</table>")
    parts.append(
        "<h3>Maps: each algorithm's runs at both ends of the deciding column</h3>"
        "<p class=\"legend\">The maps as they are: grey unknown, black occupied, white "
        "free. Click one for its detail page, with the counted corners (docs/spec.md "
        "section 3), enclosed areas (section 4), ground-truth comparison and defects as "
        "layers.</p><div class=\"gallery\">")
    for alg in ranking.order + ranking.ground_truths:
        picks = gallery.get((seq, alg), [])
        group = ok.loc[picks] if picks else ok.iloc[:0]
        key = _run_key(group, basis)
        figs = []
        ends = ("first", "last") if len(picks) > 1 else ("",)
        for which, i in zip(ends, picks):
            figs.append(_thumb(pages.get(i), ok.loc[i], which, key))
        badge = (f" <span class=\"badge\">best by {_e(basis_name(decides))}</span>"
                 if alg == ranking.winner else "")
        parts.append(f"<div class=\"card\" data-algorithm=\"{_e(alg)}\"><h4>{_e(alg)}{badge}"
                     "</h4><div class=\"pair\">" + "".join(figs) + "</div></div>")
    parts.append("</div>")
    parts.append(_runs_table(ok[ok["sequence"] == seq], pages, metrics))
    return "".join(parts)


def _thumb(mp: _MapPage | None, rec: pd.Series, which: str, key: str | None = None) -> str:
    """A gallery figure: the plain map (a badge when it has defects), its run and numbers.
    ``which`` is "first" / "last" (the ends of the run order by ``key``) or ""."""
    label = f"run {rec['run']}"
    if which and key is not None:
        higher = _METRIC_HELP[key].higher if key in _METRIC_HELP else False
        low = (which == "first") != higher
        name = _METRIC_HELP[key].label if key in _METRIC_HELP else basis_name(key)
        label += f" ({'lowest' if low else 'highest'} {name})"
    shown = METRICS + ((CANONICAL,) if key == CANONICAL.key else ())
    nums = ", ".join(f"{m.label} {format_value(_num(rec.get(m.key)))}" for m in shown
                     if usable(rec.get(m.key)) and math.isfinite(_num(rec.get(m.key))))
    if mp is None or not mp.thumb:
        why = "; ".join(mp.notes) if mp else "no detail page"
        return f"<figure><figcaption>{_e(label)}<br>{_e(nums)}<br>{_e(why)}</figcaption></figure>"
    badge = (f"<span class=\"badge\" title=\"{_e('; '.join(d['kind'] for d in mp.defects))}\">"
             f"{len(mp.defects)} defect{'s' if len(mp.defects) != 1 else ''}</span>"
             if mp.defects else "")
    return (f"<figure><a class=\"detail\" href=\"{mp.page}\"><span class=\"thumb\">"
            f"<img src=\"{mp.thumb}\" alt=\"{_e(label)}\">{badge}</span></a><figcaption>"
            f"<a href=\"{mp.page}\">{_e(label)}</a> "
            f"&middot; <a href=\"{mp.full}\">full size</a><br>{_e(nums)}</figcaption></figure>")


def _num(x: Any) -> float:
    try:
        return float(x)
    except (TypeError, ValueError):
        return math.nan


def _runs_table(sub: pd.DataFrame, pages: dict[int, _MapPage], metrics: Iterable) -> str:
    metrics = list(metrics)
    head = "".join(f"<th>{_e(m.heading)}</th>" for m in metrics)
    head += "<th title=\"mean known area relative to the most complete map of the sequence\">"
    head += "known area</th>"
    rows = []
    for i, r in sub.sort_values(["algorithm", "run"], key=lambda s: s.astype(str)).iterrows():
        mp = pages.get(i)
        link = f"<a href=\"{mp.page}\">{_e(r['run'])}</a>" if mp else _e(r["run"])
        cells = "".join(f"<td class=\"num\">{_e(format_value(_num(r.get(m.key))))}</td>"
                        for m in metrics)
        rows.append(f"<tr><td>{_e(r['algorithm'])}</td><td>{link}</td>{cells}</tr>")
    return (f"<details><summary>All {len(sub)} runs</summary><table class=\"runs\"><tr>"
            f"<th>algorithm</th><th>run</th>{head}</tr>{''.join(rows)}</table></details>")


def write_tables(summary: pd.DataFrame, out: Path) -> tuple[Path, Path]:
    """The per-sequence table of mean ± std as Markdown (``tables.md``) and LaTeX
    (``tables.tex``) for papers and READMEs.

    Examples
    --------
    >>> import tempfile, pathlib, pandas as pd
    >>> s = pd.DataFrame({"sequence": ["office"], "algorithm": ["gmapping"], "n": [3],
    ...                   "corners_mean": [12.0], "corners_std": [2.0], "corners_n": [3]}
    ...                  ).set_index(["sequence", "algorithm"])
    >>> md, tex = write_tables(s, pathlib.Path(tempfile.mkdtemp()))
    >>> print(md.read_text().splitlines()[2])
    | office | gmapping | 3 | – | – | 12 ± 2 | – |
    """
    # the ground-truth columns only when some map had a ground truth
    metrics = [m for m in METRICS if not m.key.startswith("gt_")
               or int(pd.to_numeric(summary.get(f"{m.key}_n", pd.Series(dtype=float)),
                                    errors="coerce").fillna(0).sum()) > 0]
    heads = [m.heading for m in metrics]
    md = ["| sequence | algorithm | runs | " + " | ".join(heads) + " |",
          "|---|---|---:|" + "---:|" * len(heads)]
    tex = [r"\begin{tabular}{ll r" + "r" * len(heads) + "}", r"\hline",
           "sequence & algorithm & runs & " + " & ".join(_tex(h) for h in heads) + r" \\",
           r"\hline"]
    for (seq, alg), row in summary.iterrows():
        cells = []
        for m in metrics:
            if f"{m.key}_mean" in row and int(row.get(f"{m.key}_n", 0) or 0) > 0:
                cells.append(format_mean_std(row[f"{m.key}_mean"], row[f"{m.key}_std"]))
            else:
                cells.append("–")
        n = int(row["n"])
        md.append(f"| {seq} | {alg} | {n} | " + " | ".join(cells) + " |")
        tex.append(f"{_tex(seq)} & {_tex(alg)} & {n} & "
                   + " & ".join(_tex(c).replace("±", r"$\pm$") for c in cells) + r" \\")
    tex += [r"\hline", r"\end{tabular}"]
    md_path, tex_path = out / "tables.md", out / "tables.tex"
    md_path.write_text("\n".join(md) + "\n", encoding="utf-8")
    tex_path.write_text("\n".join(tex) + "\n", encoding="utf-8")
    return md_path, tex_path


def _tex(text: str) -> str:
    """``text`` with LaTeX's special characters escaped (one pass, so that an escape is
    never escaped again).

    Examples
    --------
    >>> _tex("slam_toolbox {v2} 50% & more – \\\\")
    'slam\\\\_toolbox \\\\{v2\\\\} 50\\\\% \\\\& more -- \\\\textbackslash{}'
    """
    return re.sub(r"[\\&%$#_{}–]", lambda m: _TEX[m.group(0)], str(text))


_TEX = {"\\": r"\textbackslash{}", "&": r"\&", "%": r"\%", "$": r"\$", "#": r"\#",
        "_": r"\_", "{": r"\{", "}": r"\}", "–": "--"}
