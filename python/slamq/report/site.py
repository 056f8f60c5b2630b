"""Build the static report site: ``index.html``, one detail page per map, images beside.

Everything the pages use is in the output folder (PNG/GIF files, and the stylesheet inlined
into each page); nothing is fetched from the network and no script is needed, so the site
opens from ``file://``.

:func:`build_report` asks the verdict layer for everything it shows (:func:`slamq.verdict.
judge.judge`: the summary, the evidence, the verdicts of docs/spec.md section 9 and the
rankings; :func:`slamq.verdict.exhibits.map_exhibit`: each map loaded, scored and examined)
and hands it to the modules that draw: :mod:`~slamq.report.index` (the index page),
:mod:`~slamq.report.detail` (a map's detail page), :mod:`~slamq.report.export` (the tables
as Markdown and LaTeX), with :mod:`~slamq.report.cache` keeping unchanged detail pages.

Defects are boxes ``{"kind": str, "bbox": [col0, row0, col1, row1], "note": str}`` in the
map's cells (:mod:`slamq.verdict.exhibits`), taken from the record's ``defects`` field and
from ``build_report(..., defects_for=f)``, which calls ``f(map)`` with each loaded
:class:`~slamq.OccupancyMap` (``map.source`` is its path); by default ``f`` runs the defect
detectors the verdict reads.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

from slamq.errors import SlamqError
from slamq.report.cache import (
    page_digest,
    read_figure_cache,
    read_page_cache,
    write_page_cache,
)
from slamq.report.detail import (
    agreeing_group,
    building_directions,
    detail_page,
    path_sentence,
    standing,
)
from slamq.report.export import write_tables
from slamq.report.index import best_worst, index_body, mixed_settings, plots
from slamq.report.markup import MapPage, page
from slamq.report.markup import slug as _slug
from slamq.results.summary import spreadsheet_safe
from slamq.verdict.exhibits import detected_defects, map_exhibit
from slamq.verdict.judge import judge
from slamq.verdict.records import ResultsLike, load_results, usable

__all__ = ["AUTO_ALL_PAGES", "build_report", "write_tables"]

#: ``details="auto"`` makes a detail page for every map up to this many successful maps,
#: and for the gallery's maps only above it.
AUTO_ALL_PAGES = 60


def build_report(
    results: ResultsLike,
    out_dir: Any,
    *,
    title: str = "slamq evaluation report",
    details: str = "auto",
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
    details : {"auto", "all", "gallery"}
        Which maps get a detail page: every successful map ("all"), or the maps the index
        shows, the gallery's runs ("gallery": each algorithm's two ends of the deciding
        column in each sequence, the verdict's winner among them); "auto" (default) is
        "all" up to :data:`AUTO_ALL_PAGES` successful maps and "gallery" above. A detail
        page loads, scores and draws its map again (most of a report's time), so a batch
        of thousands of maps gets a few dozen pages; the other runs are rows of the index's
        run tables, of ``summary.csv`` and of the results file, and get their page with
        ``details="all"`` (``slamq report --details all``), kept by ``reuse`` from then on.
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
        written; its figures are kept likewise when their inputs did not change.

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
        defects_for = detected_defects
    if details not in ("auto", "all", "gallery"):
        raise SlamqError(f"details must be 'auto', 'all' or 'gallery', got {details!r}")
    frame = load_results(results)
    out = Path(out_dir)
    (out / "img").mkdir(parents=True, exist_ok=True)
    (out / "maps").mkdir(parents=True, exist_ok=True)

    failed = frame[frame["error"].map(usable)]
    ok = frame[~frame["error"].map(usable)].copy()
    judgement = judge(ok)
    summary, sequences, evidence = judgement.summary, judgement.sequences, judgement.evidence
    (out / "verdict.json").write_text(json.dumps(judgement.verdicts, indent=1) + "\n")
    verdicts, rankings = judgement.by_sequence, judgement.rankings

    pages: dict[int, MapPage] = {}
    gallery: dict[tuple[str, str], list[int]] = {}
    for seq in sequences:
        sub = ok[ok["sequence"] == seq]
        for alg, group in sub.groupby("algorithm", sort=True):
            gallery[(seq, str(alg))] = best_worst(group, verdicts[seq]["basis"])
    if details == "auto":
        details = "all" if len(ok) <= AUTO_ALL_PAGES else "gallery"
    wanted = set(ok.index) if details == "all" else {i for v in gallery.values() for i in v}
    for i in sorted(wanted):
        rec = ok.loc[i].to_dict()
        slug = f"{i:04d}-{_slug(rec['sequence'])}-{_slug(rec['algorithm'])}-{_slug(rec['run'])}"
        pages[i] = MapPage(i, rec, slug, page=f"maps/{slug}.html")
        ev = evidence.get(rec["sequence"])
        pages[i].standing = standing(rec, rankings[rec["sequence"]], summary, ev)
        if ev is not None and usable(rec.get("map")):
            pages[i].missing = ev.get("missing_walls", {}).get(str(rec["map"]))
    page_of = {str(mp.record["map"]): mp.page for mp in pages.values()
               if usable(mp.record.get("map"))}
    named = {str(r["map"]): f"{r['algorithm']}, run {r['run']}"
             for r in ok.to_dict("records") if usable(r.get("map"))}
    for mp in pages.values():
        mp.group = agreeing_group(mp.record, evidence.get(mp.record["sequence"]), page_of,
                                  named)
        mp.path = path_sentence(mp.record, evidence.get(mp.record["sequence"]))
        mp.building = building_directions(mp.record, evidence.get(mp.record["sequence"]))
    kept = read_page_cache(out) if reuse else {}
    fresh: dict[str, dict[str, Any]] = {}
    for done, mp in enumerate(pages.values(), 1):
        digest = page_digest(mp, gifs=gifs, trajectories=trajectories) if reuse else ""
        old = kept.get(mp.page)
        if old is not None and old.get("digest") == digest and all(
                (out / f).is_file() for f in (mp.page, *old.get("files", []))):
            mp.thumb, mp.full, mp.gif = old["thumb"], old["full"], old["gif"]
            mp.notes = list(old["notes"])
        else:
            exhibit = map_exhibit(mp.record, gifs=gifs, trajectories=trajectories,
                                  defects_for=defects_for)
            detail_page(mp, exhibit, out, gifs=gifs, trajectories=trajectories)
            old = None
        if reuse:
            fresh[mp.page] = {"digest": digest, "thumb": mp.thumb, "full": mp.full,
                              "gif": mp.gif, "notes": mp.notes, "reused": old is not None,
                              "files": [f for f in (mp.thumb, mp.full, mp.gif) if f]}
        if progress is not None:
            progress(done, len(pages))
    figures = read_figure_cache(out) if reuse else None
    made = plots(ok, out, sequences, cache=figures)
    if reuse:
        write_page_cache(out, fresh, figures)
    body = index_body(title, frame, ok, failed, summary, sequences, rankings, verdicts,
                      gallery, pages, made, mixed_settings(frame))
    index = out / "index.html"
    index.write_text(page(title, body), encoding="utf-8")
    write_tables(summary, out)
    spreadsheet_safe(summary.reset_index()).to_csv(out / "summary.csv", index=False)
    return index
