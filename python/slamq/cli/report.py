"""``slamq report RESULTS --out DIR``: the evaluation report as a static site."""

from __future__ import annotations

import argparse

from slamq.cli.common import EXIT_OK, Progress, need_extra


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Register ``slamq report``."""
    p = subparsers.add_parser(
        "report",
        help="write an HTML evaluation report (tables, plots, map gallery) from results",
        description="Write a self-contained HTML report (no server, no internet) from a "
        "results file written by `slamq batch` (.jsonl, .parquet) or `slamq eval` (.json, .csv).",
    )
    p.add_argument("results", help="results file (.jsonl, .parquet, .json or .csv)")
    p.add_argument("--out", required=True, metavar="DIR", help="folder to write the site to")
    p.add_argument("--title", default="slamq evaluation report", help="page title")
    p.add_argument("--details", choices=("auto", "all", "gallery"), default="auto",
                   help="detail pages for every map, or only for the gallery's runs (each "
                   "algorithm's two ends of the deciding column, the winner among them); "
                   "auto: every map up to 60 maps, the gallery's above (default %(default)s)")
    p.add_argument("--redraw", action="store_true",
                   help="draw every page and figure again (by default those of an earlier "
                   "report in --out whose inputs did not change are kept)")
    p.add_argument("--no-gifs", action="store_true",
                   help="skip map-building animations from snapshots")
    p.add_argument("--no-trajectories", action="store_true",
                   help="skip drawing trajectories over maps")
    p.set_defaults(func=handle)


def handle(args: argparse.Namespace) -> int:
    """Build the report; print where it is."""
    need_extra("report", "slamq report")
    from slamq.report import build_report

    with Progress("slamq report", "pages", not args.quiet) as progress:
        index = build_report(
            args.results, args.out, title=args.title, details=args.details,
            gifs=not args.no_gifs, trajectories=not args.no_trajectories,
            progress=progress.update, reuse=not args.redraw,
        )
    print(f"report written: {index}")
    return EXIT_OK
