"""``slamq summary RESULTS``: mean +- std per (algorithm, sequence) of any results file."""

from __future__ import annotations

import argparse

from slamq.cli.common import EXIT_BAD_INPUT, EXIT_OK, error_line, stdout_console


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Register ``slamq summary``."""
    s = subparsers.add_parser(
        "summary",
        help="mean and std per (algorithm, sequence) of a results file",
        description="Print mean ± standard deviation over runs of the metrics, per "
        "(algorithm, sequence), from a results file written by `slamq batch` (.parquet, "
        ".jsonl) or `slamq eval` (.json, .csv).",
    )
    s.add_argument("results", help="results file (.parquet, .jsonl, .json or .csv)")
    s.add_argument("--ddof", type=int, default=1, choices=(0, 1),
                   help="standard deviation: 1 = sample (default), 0 = population")
    s.add_argument("--csv", metavar="FILE", help="also write the summary as CSV")
    s.add_argument("--json", metavar="FILE", help="also write the summary as JSON")
    s.set_defaults(func=handle)


def handle(args: argparse.Namespace) -> int:
    """Print the summary table; optionally write it as CSV / JSON."""
    # plain rows, not a DataFrame: printing the table imports neither pandas nor numpy
    # (most of the command's time); writing --csv / --json does, to write what it did
    from slamq.results.summary import spreadsheet_safe, summary_rows, summary_table

    columns, rows = summary_rows(args.results, ddof=args.ddof)
    if not rows:
        error_line(args.results, "no records")
        return EXIT_BAD_INPUT
    stdout_console().print(summary_table(rows, title=str(args.results)))
    if args.csv or args.json:
        import pandas as pd

        summary = pd.DataFrame(rows, columns=columns)
        if args.csv:
            spreadsheet_safe(summary).to_csv(args.csv, index=False)
        if args.json:
            summary.to_json(args.json, orient="records", indent=1)
    return EXIT_OK
