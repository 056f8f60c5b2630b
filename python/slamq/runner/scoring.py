"""Stage 5 of a run, scoring: the collected runs scored, summarised, drawn and reported.

Takes the rows of the finished runs (what :func:`slamq.runner.execution.run_row` gives:
outcome, collected ``map`` and ``trajectory``, folder) and the configuration; gives, in
the output folder, ``results.jsonl`` (one record per map from
:func:`slamq.batch.evaluate_many`, with the sequence's ground truth: ``ate_*``, ``gt_*``
and, with a ``relations:`` file, ``rel_*``), ``runs.csv``,
``scores.csv`` and ``summary.csv`` (:mod:`slamq.runner.resources`: mean and standard
deviation per algorithm[variant] and sequence, failure rate, time and memory), a
``building.gif`` per run from its snapshots, and the HTML report
(:func:`slamq.report.build_report`). :func:`score` does all of it; what did not change
since the last call is skipped (:mod:`slamq.runner.cache`).

Before: :mod:`slamq.runner.collection` collected each run's outputs.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

from slamq.errors import SlamqError
from slamq.runner.config import RunConfig

__all__ = ["need_report_extra", "score"]


def score(config: RunConfig, rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Score the runs with the batch engine, summarise, write GIFs and the report.

    What did not change since the last call is skipped (:mod:`slamq.runner.cache`): a run
    is scored again only when its map, trajectory, ground truth (trajectory, map or
    relations file), place, the ``evaluate`` settings or slamq's version changed (or its
    record is missing or failed); a GIF when its snapshots changed; the report when any of
    its inputs did. ``stages`` in the result says what was done and skipped, and why (also
    ``OUTPUT/stages.jsonl``).
    """
    import pandas as pd

    from slamq.batch import Run
    from slamq.results import summarize
    from slamq.results.summary import spreadsheet_safe
    from slamq.runner.cache import Stamps

    seqs = {s.name: s for s in config.sequences}
    runs = []
    for r in rows:
        if r.get("outcome") not in ("ok", "degenerate") or not r.get("map"):
            continue
        seq = seqs.get(r["sequence"])
        runs.append(Run(r["map"], r["algorithm"], r["sequence"], str(r["iteration"]),
                        trajectory=r.get("trajectory"),
                        groundtruth=seq.groundtruth if seq else None,
                        gt_map=seq.groundtruth_map if seq else None,
                        relations=seq.relations if seq else None,
                        scans=seq.input if seq else None))
    out = config.output
    results_path = out / "results.jsonl"
    stamps = Stamps(out)
    stages = []
    scored, run_stamps, stage = _score_changed(config, runs, results_path, stamps)
    stages.append(stage)
    table = pd.DataFrame(rows)
    table.drop(columns=[c for c in ("command", "skipped") if c in table], errors="ignore") \
        .to_csv(out / "runs.csv", index=False)
    summary = None
    if results_path.exists():
        summary = summarize(results_path)
        counts = table.groupby(["algorithm", "sequence"])["outcome"].agg(
            runs="size", ok=lambda s: int((s == "ok").sum()))
        counts["failure_rate"] = 1 - counts["ok"] / counts["runs"]
        summary = summary.merge(counts.reset_index(), on=["algorithm", "sequence"], how="outer")
    from slamq.runner.resources import resource_summary, write_scores

    scores = write_scores(out, rows, results_path)
    if summary is not None:
        summary = resource_summary(summary, scores)
        spreadsheet_safe(summary).to_csv(out / "summary.csv", index=False)
    gifs, snap_stamps, stage = _gifs(rows, stamps, out)
    stages.append(stage)
    report = None
    if config.report and results_path.exists():
        report, stage = _report(config, scores, results_path, stamps, run_stamps,
                                snap_stamps)
        stages.append(stage)
    return {"results": results_path, "records": scored, "summary": summary,
            "gifs": gifs, "report": report, "stages": stages}


def _why(reasons: dict[str, list[str]], limit: int = 3) -> str:
    """``"a: map changed; b: new"`` for the first ``limit`` items, then ``+N more``."""
    items = [f"{k}: {', '.join(v)}" for k, v in reasons.items()]
    more = f"; +{len(items) - limit} more" if len(items) > limit else ""
    return "; ".join(items[:limit]) + more


_INPUT_NAMES = {"new": "not done before", "record": "no stored record (or it failed)",
                "map": "map changed", "trajectory": "trajectory changed",
                "groundtruth": "ground truth changed", "gt_map": "ground-truth map changed",
                "relations": "relations file changed",
                "settings": "evaluate settings changed", "version": "slamq version changed",
                "columns": "slamq computes other columns", "scans": "scans recording changed",
                "place": "other paths or names", "snapshots": "snapshots changed",
                "gif": "GIF missing", "size": "other frame size"}


def _score_changed(config: RunConfig, runs: list[Any], results_path: Path, stamps: Any
                   ) -> tuple[int, dict[str, Any], dict[str, Any]]:
    """Score the runs whose inputs changed (see :func:`score`); append their records to
    the results file (a re-scored run's old record is replaced). Returns the number scored,
    each run's stamp and the stage's log line."""
    from slamq.batch import evaluate_many
    from slamq.columns import record_columns
    from slamq.results.store import ResultsFile
    from slamq.runner.cache import changes, file_digest, log_stage, map_digest, stamp
    from slamq.version import __version__

    # what changes a record (not where or how fast it is computed)
    settings = stamp({k: v for k, v in config.evaluate.items()
                      if k not in ("threads", "executor", "chunk_size")})
    # a record lacking a column this slamq computes (a new one) is scored again
    columns = stamp(list(record_columns()))
    digests: dict[str, str | None] = {}

    def once(kind: str, path: Any) -> str | None:
        if path is None:
            return None
        key = f"{kind}:{path}"
        if key not in digests:
            digests[key] = map_digest(path) if kind == "map" else file_digest(path)
        return digests[key]

    stored: set[str] = set()
    if results_path.exists() and runs:
        with ResultsFile(results_path) as rf:
            stored = {json.dumps(list(k)) for k, rec in rf.done()
                      if rec.get("error") in (None, "")}
    run_stamps: dict[str, Any] = {}
    todo, reasons = [], {}
    for run in runs:
        item = json.dumps([str(x) for x in run.key])
        new = {"map": once("map", run.map), "trajectory": once("file", run.trajectory),
               "groundtruth": once("file", run.groundtruth),
               "gt_map": once("map", run.gt_map), "settings": settings,
               "version": __version__, "columns": columns,
               "place": stamp([str(x) for x in (*run.key, run.trajectory, run.groundtruth,
                                                 run.gt_map)])}
        if run.relations is not None:  # absent before relations existed: no rescoring
            new["relations"] = once("file", run.relations)
            new["place"] = stamp([new["place"], str(run.relations)])
        if run.scans is not None:  # a record scored before it named its scans gets them
            new["scans"] = str(run.scans)
        run_stamps[item] = new
        why = changes(stamps.get("score", item), new)
        if not why and item not in stored:
            why = ["record"]
        if why:
            todo.append(run)
            reasons[f"{run.algorithm} {run.sequence} #{run.run}"] = [
                _INPUT_NAMES.get(w, w) for w in why]
            stamps.drop("score", item)
    records = 0
    if todo:
        chunk: list[dict[str, Any]] = []
        with ResultsFile(results_path) as rf:
            for rec in evaluate_many(todo, **config.evaluate):
                chunk.append(rec)
                records += 1
                if len(chunk) >= 32:
                    rf.append(chunk)
                    chunk = []
            rf.append(chunk)
        _keep_order(results_path, runs)
        for run in todo:
            item = json.dumps([str(x) for x in run.key])
            stamps.put("score", item, run_stamps[item])
        stamps.save()
    skipped = len(runs) - len(todo)
    message = f"scores: {len(todo)} of {len(runs)} maps scored"
    if todo:
        message += f" ({_why(reasons)})"
    if skipped:
        message += (f"; {skipped} skipped (map, trajectory, ground truth, settings and "
                    "slamq version as when they were scored)")
    stage = log_stage(config.output, "score", len(todo), skipped, message, why=reasons)
    return records, run_stamps, stage


def need_report_extra(cfg: RunConfig) -> None:
    """The report (``report: true``) draws with matplotlib and Pillow, the ``report`` extra:
    say so before anything runs."""
    import importlib.util

    missing = [m for m in ("matplotlib", "PIL") if importlib.util.find_spec(m) is None]
    if missing:
        raise SlamqError(f"{cfg.source}: report: true needs the 'report' extra "
                         f"({', '.join(missing)} not installed): pip install 'slamq[report]', "
                         "or set report: false")


def _keep_order(results_path: Path, runs: list[Any]) -> None:
    """Put the records of ``results_path`` (JSON Lines) back in the order of ``runs`` (a
    re-scored run's record was appended last), so that the report's pages keep their
    names; records of runs not planned any more stay, after them. Rewritten atomically,
    only when the order changed."""
    from slamq.results.formats import dumps_record, iter_jsonl

    order = {tuple(str(x) for x in r.key): i for i, r in enumerate(runs)}
    records = list(iter_jsonl(results_path))

    def position(ir: tuple[int, dict[str, Any]]) -> tuple[int, int]:
        i, rec = ir
        key = tuple(str(rec.get(k)) for k in ("algorithm", "sequence", "run", "map"))
        return (order[key], 0) if key in order else (len(order), i)

    ranked = sorted(enumerate(records), key=position)
    if [i for i, _ in ranked] == list(range(len(records))):
        return
    tmp = results_path.with_name(results_path.name + ".tmp")
    with open(tmp, "w", encoding="utf-8") as f:
        f.write("".join(dumps_record(rec) for _, rec in ranked))
    os.replace(tmp, results_path)


def _gifs(rows: list[dict[str, Any]], stamps: Any, output: Path
          ) -> tuple[list[Path], dict[str, Any], dict[str, Any]]:
    """A ``building.gif`` per run from its collected snapshots (the report's renderer),
    made again only when its snapshots changed; none without Pillow (the ``report``
    extra). Returns the GIFs, each run's snapshot stamp and the stage's log line."""
    import importlib.util

    from slamq.runner.cache import changes, log_stage, snapshots_digest
    from slamq.version import __version__

    made: list[Path] = []
    snap_stamps: dict[str, Any] = {}
    if importlib.util.find_spec("PIL") is None:
        stage = log_stage(output, "gifs", 0, 0, "GIFs: none (Pillow is not installed)")
        return made, snap_stamps, stage
    from slamq.report.animation import render_frames, write_gif
    from slamq.sources.maps import load_map
    from slamq.sources.snapshots import find_snapshots

    drawn, kept, reasons = 0, 0, {}
    for r in rows:
        folder = Path(r["folder"])
        gif = folder / "building.gif"
        digest = snapshots_digest(folder)
        snap_stamps[str(folder)] = digest
        if digest is None:
            continue
        new = {"snapshots": digest, "size": 400, "version": __version__}
        why = changes(stamps.get("gif", str(folder)), new)
        if not why and not gif.exists():
            why = ["gif"]
        if not why:
            made.append(gif)
            kept += 1
            continue
        stamps.drop("gif", str(folder))
        reasons[f"{r['algorithm']} {r['sequence']} #{r['iteration']}"] = [
            _INPUT_NAMES.get(w, w) for w in why]
        try:
            maps = [load_map(p) for p in find_snapshots(folder)]
            made.append(write_gif(render_frames(maps, max_size=400), gif))
        except (SlamqError, OSError):
            continue
        stamps.put("gif", str(folder), new)
        drawn += 1
    if drawn:
        stamps.save()
    message = f"GIFs: {drawn} of {drawn + kept} made"
    if reasons:
        message += f" ({_why(reasons)})"
    if kept:
        message += f"; {kept} skipped (snapshots as when they were drawn)"
    stage = log_stage(output, "gifs", drawn, kept, message, why=reasons)
    return made, snap_stamps, stage


def _report(config: RunConfig, scores: Any, results_path: Path, stamps: Any,
            run_stamps: dict[str, Any], snap_stamps: dict[str, Any]
            ) -> tuple[Path, dict[str, Any]]:
    """Write the report, or skip it when none of its inputs changed since it was written
    (and ``report/index.html`` is that file)."""
    from slamq.report import build_report
    from slamq.report.resources import resources_page
    from slamq.runner.cache import changes, file_digest, log_stage, stamp
    from slamq.version import __version__

    out = config.output
    index = out / "report" / "index.html"
    title = "slamq run report"
    new = {"results": file_digest(results_path), "scores": file_digest(out / "scores.csv"),
           "runs": stamp(run_stamps), "snapshots": stamp(snap_stamps), "title": title,
           "version": __version__}
    old = stamps.get("report", "report")
    why = changes(old.get("inputs") if isinstance(old, dict) else None, new)
    if not why and (not index.is_file() or file_digest(index) != old.get("index")):
        why = ["index"]
    if not why:
        stage = log_stage(out, "report", 0, 1, "report: skipped (results, scores, maps, "
                          "snapshots and slamq version as when it was written)")
        return index, stage
    names = {"results": "results changed", "scores": "scores.csv changed",
             "runs": "a map, trajectory or ground truth changed",
             "snapshots": "snapshots changed", "index": "report/index.html missing or "
             "edited", "new": "not written before", "version": "slamq version changed",
             "title": "other title"}
    stamps.drop("report", "report")
    stamps.save()
    report = build_report(results_path, out / "report", title=title, reuse=True)
    resources_page(scores, out / "report", config=config.source)
    stamps.put("report", "report", {"inputs": new, "index": file_digest(report)})
    stamps.save()
    try:  # how many detail pages build_report drew and kept
        pages = json.loads((out / "report" / ".pages.json").read_text())
        drawn, reused = int(pages["drawn"]), int(pages["reused"])
    except (OSError, ValueError, KeyError, TypeError):
        drawn, reused = 0, 0
    message = (f"report: written ({', '.join(names.get(w, w) for w in why)}); "
               f"detail pages: {drawn} drawn, {reused} kept (record, map, trajectory, "
               "ground truth and snapshots as when they were drawn)")
    return report, log_stage(out, "report", 1, 0, message, why=why, pages_drawn=drawn,
                             pages_kept=reused)


