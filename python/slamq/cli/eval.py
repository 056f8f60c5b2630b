"""``slamq eval PATH...``: the three map metrics of maps, folders (recursive) and bags.

Follow one map: :func:`run` -> :func:`slamq.evaluate` (python/slamq/metrics/evaluate.py)
-> ``slamq._core.evaluate`` (rust/src/python.rs) -> rust/src/evaluate.rs -> the metric's
file (rust/src/proportion.rs, corners.rs, enclosed.rs).
"""

from __future__ import annotations

import argparse

from slamq.cli.common import EXIT_BAD_INPUT, EXIT_ERROR, EXIT_OK, add_map_options, error_line


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Register ``slamq eval``."""
    p = subparsers.add_parser(
        "eval",
        help="the three map metrics of one or more maps",
        description="Evaluate maps (YAML + image, or images; folders are searched "
        "recursively with the rules slamq batch uses; an image named by a YAML beside it is "
        "evaluated once, through the YAML).",
    )
    p.add_argument("paths", nargs="+", help="map files or folders")
    p.add_argument("--json", metavar="FILE", help="write the results as JSON")
    p.add_argument("--csv", metavar="FILE", help="write the results as CSV")
    p.add_argument("--curve", action="store_true",
                   help="keep the enclosed-area curve over the unknown value")
    p.add_argument("--verify", action="store_true",
                   help="also run slamq.metrics.reference (slow) and fail on any difference")
    p.add_argument("--threads", type=int, default=None, help="cap on worker threads")
    add_map_options(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Evaluate every map found; one error line per bad map, the others still evaluated."""
    from slamq.errors import SlamqError
    from slamq.metrics.evaluate import evaluate
    from slamq.params import check_threads, params_from_args
    from slamq.results.files import write_csv, write_json
    from slamq.results.table import print_table
    from slamq.sources.walk import discover_maps

    params = params_from_args(args)
    check_threads(args.threads, "--threads")
    failed = unexpected = 0
    sources, problems = discover_maps(args.paths)
    for where, reason in problems:
        error_line(where, reason)
        failed += 1
    results = []
    for src in sources:
        try:
            q = evaluate(src, params=params, curve=args.curve, verify=args.verify,
                         threads=args.threads, unknown_value=args.unknown_value)
        except SlamqError as exc:
            error_line(str(src), exc)
            failed += 1
            continue
        except Exception as exc:  # noqa: BLE001 - a bug on one map must not cost the others
            error_line(str(src), f"unexpected {type(exc).__name__}: {exc}")
            unexpected += 1
            continue
        results.append(q)
    if results:
        print_table(results, curve=args.curve)
    if args.json:
        write_json(args.json, results)
    if args.csv:
        write_csv(args.csv, results)
    if unexpected:
        return EXIT_ERROR
    if not results and not failed:
        error_line("", "no map found in " + ", ".join(map(str, args.paths)))
        return EXIT_BAD_INPUT
    return EXIT_BAD_INPUT if failed else EXIT_OK
