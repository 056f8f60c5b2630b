"""``slamq eval PATH...``: the three map metrics of maps, folders (recursive) and bags.

Follow one map: :func:`run` -> :func:`slamq.evaluate` (python/slamq/metrics/evaluate.py)
-> ``slamq._core.evaluate`` (rust/src/bindings/maps.rs) -> rust/src/evaluate.rs -> the metric's
file (rust/src/proportion.rs, corners.rs, enclosed.rs).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from slamq.cli.common import (
    Progress,
    add_map_options,
    add_table_output_options,
    add_threads_option,
    error_line,
    exit_code,
)
from slamq.cli.common import (
    error_text as _error_text,
)


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Register ``slamq eval``."""
    p = subparsers.add_parser(
        "eval",
        help="the three map metrics of one or more maps",
        description="Evaluate maps (YAML + image, or images; folders are searched "
        "recursively with the rules slamq batch uses; an image named by a YAML beside it is "
        "evaluated once, through the YAML).",
    )
    p.add_argument("paths", nargs="+",
                   help="map files or folders; '-' reads one map image (PGM, PNG, ...) "
                   "from standard input")
    add_table_output_options(p)
    p.add_argument("--curve", action="store_true",
                   help="keep the enclosed-area curve over the unknown value")
    p.add_argument("--verify", action="store_true",
                   help="also run slamq.metrics.reference (slow) and fail on any difference")
    add_threads_option(p)
    add_map_options(p)
    p.set_defaults(func=handle)


def handle(args: argparse.Namespace) -> int:
    """Evaluate every map found; one error line per bad map, the others still evaluated."""
    from slamq.errors import ParamError, SlamqError
    from slamq.metrics.evaluate import evaluate
    from slamq.params import check_threads, params_from_args
    from slamq.results.table import print_table
    from slamq.sources.walk import discover_maps

    params = params_from_args(args)
    check_threads(args.threads, "--threads")
    if args.json == "-" and args.csv == "-":
        raise ParamError("--json - and --csv - cannot both write to standard output")
    failed = unexpected = 0
    stdin = "-" in args.paths
    sources, problems = discover_maps([p for p in args.paths if p != "-"])
    if stdin:
        sources.insert(args.paths.index("-"), STDIN)
    for where, reason in problems:
        error_line(where, reason)
        failed += 1
    results = []
    with Progress("slamq eval", "maps", len(sources) > 1 and not args.quiet) as progress:
        for done, src in enumerate(sources, 1):
            progress.update(done - 1, len(sources))
            try:
                grid = _load(src, args)
                q = evaluate(grid, params=params, curve=args.curve, verify=args.verify,
                             threads=args.threads)
            except SlamqError as exc:
                progress.line(_error_text(str(src), exc))
                failed += 1
                continue
            except Exception as exc:  # noqa: BLE001 - a bug on one map must not cost others
                progress.line(_error_text(str(src), f"unexpected {type(exc).__name__}: {exc}"))
                unexpected += 1
                continue
            results.append(q)
        progress.update(len(sources), len(sources))
    to_stdout = "-" in (args.json, args.csv)
    if results and not args.quiet:
        print_table(results, curve=args.curve, file=sys.stderr if to_stdout else sys.stdout)
    if len(results) > 1:
        import pandas as pd

        from slamq.cli.common import cli_words
        from slamq.results.summary import comparability_warnings

        for msg in comparability_warnings(pd.DataFrame([q.to_dict() for q in results])):
            print(f"slamq: warning: {cli_words(msg.split(': ', 1)[1])}", file=sys.stderr)
    if args.json or args.csv:  # the file formats only when a file is asked for
        from slamq.results.formats import write_csv, write_json

        if args.json:
            write_json(sys.stdout if args.json == "-" else args.json, results)
        if args.csv:
            write_csv(sys.stdout if args.csv == "-" else args.csv, results)
    return exit_code(len(results), failed, unexpected, args.paths)


#: Stands for standard input among the sources.
STDIN = Path("-")


def _load(src: Path, args: argparse.Namespace) -> Any:
    """The map of one source: standard input (an image's bytes), a bag on ``--topic``, or
    a file."""
    from slamq.sources import load_map
    from slamq.sources.files import MAX_IMAGE_BYTES
    from slamq.sources.maps import load_map_bytes

    if src is STDIN:
        data = sys.stdin.buffer.read(MAX_IMAGE_BYTES + 1)
        return load_map_bytes(data, unknown_value=args.unknown_value)
    return load_map(src, unknown_value=args.unknown_value, topic=args.topic)
