"""``slamq batch``: the command-line face of :mod:`slamq.batch`.

``slamq batch DIR_OR_MANIFEST... --out results.parquet`` evaluates every run it finds,
with a progress bar on stderr (when stderr is a terminal), one stderr line per failed map,
a summary table on stdout, and exit code 2 when some maps failed. Rerunning the same
command resumes: maps already in the results file are skipped.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path
from typing import Any

from slamq.cli.common import (
    EXIT_BAD_INPUT,
    EXIT_OK,
    Progress,
    add_compare_options,
    add_map_options,
    error_line,
    need_extra,
    stdout_console,
)
from slamq.params import SETTINGS

__all__ = ["add_parser"]


def add_parser(subparsers: Any) -> None:
    """Register ``slamq batch``."""
    p = subparsers.add_parser(
        "batch",
        help="evaluate many maps (folders of runs or a manifest), resumable",
        description=(
            "Evaluate every run under the given folders / manifest CSV files and append the "
            "records to a results file as chunks finish. Layouts: <algorithm>/<sequence>/"
            "<run>/ folders holding one map (and optionally a trajectory), or flat "
            "<sequence>/<algorithm>_map.yaml folders; a manifest CSV has the columns "
            "algorithm, sequence, run, map, trajectory, groundtruth, gt_map, scans (paths "
            "relative to it; scans: the recording with the laser scans the map was built "
            "from, which the report's verdict scores the map against). A sequence's "
            "ground-truth map (<sequence>_ground_truth, "
            "ground_truth*.yaml or gt_map.yaml in the sequence folder, or the gt_map column) "
            "adds gt_* columns (slamq compare) to every other run of the sequence; its "
            "relations file (<sequence>.relations beside the runs, the relations column, or "
            "--relations) adds rel_* columns (slamq relations) to every run with a "
            "trajectory. Rerunning the same command skips maps already in the results file."
        ),
    )
    p.add_argument("sources", nargs="+", metavar="DIR_OR_MANIFEST",
                   help="folders, manifest .csv files or map files")
    p.add_argument("--out", "-o", metavar="FILE", default=None,
                   help="results file, .parquet or .jsonl (default: results.parquet, or "
                   "DIR/results.parquet with --report DIR)")
    SETTINGS.threads.add_option(p, note="with Dask: per chunk in a worker")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   default=os.environ.get("DASK_SCHEDULER_ADDRESS") or None,
                   help="Dask scheduler (tcp://host:8786) to send chunks of maps to; 'dask' "
                   "starts a local cluster, 'local' forces local threads (default: "
                   "$DASK_SCHEDULER_ADDRESS, else local threads)")
    p.add_argument("--chunk-size", type=int, default=None,
                   help="maps per results-file append and per Dask task (default 32)")
    p.add_argument("--curve", action="store_true",
                   help="keep the enclosed-area curve in the records")
    p.add_argument("--verify", action="store_true",
                   help="also run slamq.metrics.reference (slow) on every map")
    SETTINGS.ate_align.add_option(p, "--align", dest="align")
    SETTINGS.max_dt.add_option(p)
    SETTINGS.unsorted.add_option(p, note="error: an ATE error in the record")
    add_compare_options(p, "gt-")  # each map against its sequence's ground-truth map
    p.add_argument("--relations", metavar="[SEQUENCE=]FILE", action="append", default=None,
                   help="relations file (Kümmerle et al. 2009) of every run with a trajectory "
                   "and none found beside it, or SEQUENCE=FILE for one sequence (repeat); "
                   "adds the rel_* columns (docs/spec.md 6a)")
    p.add_argument("--rel-interpolate", action="store_true",
                   help="relations: place a stamp between the two neighbouring poses when no "
                   "pose is at it (slamq relations --interpolate)")
    p.add_argument("--rel-max-gap", metavar="S", type=float, default=None,
                   help="relations: largest time between two poses interpolated between "
                   "(default 0.5, as slamq relations --max-gap)")
    p.add_argument("--report", metavar="DIR", default=None,
                   help="then write the HTML report of the results to DIR (slamq report)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--dry-run", action="store_true",
                   help="print the algorithm / sequence / run of every map found (and the "
                   "layout that was detected), and evaluate nothing")
    add_map_options(p)
    p.set_defaults(func=handle)


def handle(args: argparse.Namespace) -> int:
    from slamq.batch import evaluate_many
    from slamq.batch.runs import Discovery, describe_layout
    from slamq.errors import SlamqError
    from slamq.params import params_from_args
    from slamq.results import read_results, summarize, summary_table

    if args.report:
        need_extra("report", "slamq batch --report")
    if args.dry_run:  # lists every run: the one mode that holds them all
        from slamq.batch import discover_runs

        found = discover_runs(args.sources)
        _print_runs(found)
        for line in describe_layout(found):
            print(line)
        return EXIT_OK if found else EXIT_BAD_INPUT
    # counted and summarised by one walk, read back from a temporary file as they are
    # evaluated: no list of every run in memory
    runs = Discovery(args.sources)
    if not args.quiet:
        for line in runs.layout_lines():
            print(f"slamq batch: {line}" if not line.startswith("warning:")
                  else f"slamq: {line}", file=sys.stderr)

    out = Path(args.out) if args.out else (
        Path(args.report) / "results.parquet" if args.report else Path("results.parquet")
    )
    executor: Any = None
    if args.scheduler and args.scheduler != "local":
        executor = args.scheduler
    params = params_from_args(args).to_dict()
    params.update(unknown_value=args.unknown_value, curve=args.curve, verify=args.verify)
    try:
        relations = _relations_arg(args.relations)
    except SlamqError as exc:
        error_line("", exc)
        return EXIT_BAD_INPUT
    failed = 0
    no_ate: dict[str, int] = {}  # why an evaluated map has no ATE -> how many
    evaluated = 0
    total = 0
    seen = 0  # maps evaluated or skipped
    with Progress("slamq batch", "maps", not args.no_progress and not args.quiet) as progress:

        def on_progress(done: int, n: int) -> None:
            nonlocal total, seen
            total, seen = n, done
            progress.update(done, max(n, done))

        try:
            records = evaluate_many(
                runs, threads=args.threads, executor=executor,
                chunk_size=args.chunk_size, out=out, progress=on_progress,
                ate_align=args.align, ate_max_dt=args.max_dt, ate_unsorted=args.unsorted,
                gt_align=args.gt_align, gt_tolerance=args.gt_tolerance,
                gt_max_distance=args.gt_max_distance, relations=relations,
                rel_interpolate=args.rel_interpolate, rel_max_gap=args.rel_max_gap, **params,
            )
            for rec in records:
                evaluated += 1
                if rec.get("error"):
                    failed += 1
                    progress.line(f"slamq: error: {rec['error']}")
                else:
                    why = _why_no_ate(rec)
                    if why is not None:
                        no_ate[why] = no_ate.get(why, 0) + 1
                    if rec.get("ate_error"):
                        progress.line(f"slamq: warning: no ATE: {rec['ate_error']}")
        except SlamqError as exc:
            error_line("", exc)
            return EXIT_BAD_INPUT
        except KeyboardInterrupt:
            progress.line(
                f"slamq batch: interrupted after {evaluated} map(s); every finished chunk is "
                f"in {out}: run the same command again to resume")
            raise
    skipped = seen - evaluated
    print(
        f"slamq batch: {evaluated} map(s) evaluated, {skipped} already in {out}, "
        f"{failed} failed, {_no_ate_text(no_ate)}; results in {out}",
        file=sys.stderr,
    )
    if total == 0 and seen == 0:
        error_line("", "no map found in " + ", ".join(map(str, args.sources)))
        return EXIT_BAD_INPUT
    if not args.quiet:  # -q/--quiet: every command has it
        stdout_console().print(summary_table(summarize(read_results(out)), title=str(out)))
    if args.report:
        from slamq.report import build_report

        print(f"report written: {build_report(out, args.report)}")
    return EXIT_BAD_INPUT if failed else EXIT_OK


def _relations_arg(values: list[str] | None) -> Any:
    """``--relations`` as ``relations=`` of :func:`slamq.evaluate_many`: one file, or
    ``{sequence: file}``; each file must exist.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "a.relations"; _ = f.write_text("")
    >>> _relations_arg([f"intel={f}"]) == {"intel": str(f)}, _relations_arg(None)
    (True, None)
    """
    from slamq.errors import ParamError

    if not values:
        return None
    files: dict[str, str] = {}
    every = None
    for v in values:
        seq, eq, path = v.partition("=")
        if not eq or not seq or os.path.exists(v):
            seq, path = "", v
        if not os.path.isfile(path):
            raise ParamError(f"{path}: --relations: no such file")
        if seq:
            files[seq] = path
        elif every is not None:
            raise ParamError("--relations FILE is given twice; name each sequence's file "
                             "with --relations SEQUENCE=FILE")
        else:
            every = path
    if every is not None and files:
        raise ParamError("--relations: give one FILE for every run, or SEQUENCE=FILE for "
                         "each sequence, not both")
    return every if every is not None else files


def _why_no_ate(rec: dict) -> str | None:
    """Why an evaluated map's record has no ATE (None when it has one).

    Examples
    --------
    >>> _why_no_ate({"ate_rmse": 0.1}) is None
    True
    >>> _why_no_ate({"trajectory": "est.txt", "groundtruth": None})
    'no ground truth'
    """
    import math

    rmse = rec.get("ate_rmse")
    if isinstance(rmse, (int, float)) and math.isfinite(rmse):
        return None
    if rec.get("ate_error"):
        return "ATE failed"
    from slamq.batch.runs import is_ground_truth

    if is_ground_truth(str(rec.get("algorithm", ""))):
        return "reference map"
    if not rec.get("trajectory"):
        return "no trajectory"
    if not rec.get("groundtruth"):
        return "no ground truth"
    return "ATE failed"


def _no_ate_text(no_ate: dict[str, int]) -> str:
    """``"3 without ATE (2 no trajectory, 1 reference map)"``, or ``"0 without ATE"``.

    Examples
    --------
    >>> _no_ate_text({"no trajectory": 2, "ATE failed": 1})
    '3 without ATE (1 ATE failed, 2 no trajectory)'
    """
    total = sum(no_ate.values())
    if not total:
        return "0 without ATE"
    why = ", ".join(f"{n} {k}" for k, n in sorted(no_ate.items()))
    return f"{total} without ATE ({why})"


def _print_runs(runs: list) -> None:
    """The runs a batch would evaluate, one line each (``--dry-run``)."""
    from slamq.results.table import short_names

    names = short_names([str(r.map) for r in runs])
    from slamq.batch.runs import is_ground_truth

    rows = [("algorithm", "sequence", "run", "layout", "map", "trajectory", "groundtruth",
             "gt_map")]
    for r in runs:
        rows.append((r.algorithm, r.sequence, r.run, r.layout, names[str(r.map)],
                     r.trajectory.name if r.trajectory else "-",
                     r.groundtruth.name if r.groundtruth else "-",
                     "(reference)" if is_ground_truth(r.algorithm) else
                     r.gt_map.name if r.gt_map else "-"))
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    for row in rows:
        print("  ".join(c.ljust(w) for c, w in zip(row, widths)).rstrip())
