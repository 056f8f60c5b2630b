"""``slamq run CONFIG --shard I/N`` and ``--merge``: the array-job half of ``slamq run``."""

from __future__ import annotations

import argparse
import sys
from typing import Any, Callable

from slamq.cli.common import EXIT_OK
from slamq.errors import ParamError


def shard_or_merge(args: argparse.Namespace, progress: Callable[[dict], Any]) -> int:
    """Run one shard (nothing scored) or merge the finished runs; print where things are."""
    from slamq.runner import shards

    if args.shard and (args.merge or args.scheduler or args.dry_run):
        raise ParamError("--shard runs one slice locally: not with --merge, --scheduler or "
                         "--dry-run")
    if args.shard:
        i, n = shards.parse_shard(args.shard)
        result = shards.run_shard(args.config, (i, n), retry_failed=args.retry_failed,
                                  progress=progress)
        counts = _counts(result["rows"])
        print(f"shard {i}/{n}: {len(result['rows'])} runs ({counts}); record: "
              f"{result['record']}")
        print(f"when every shard is done: slamq run {args.config} --merge")
        return EXIT_OK
    result = shards.merge(args.config)
    print(f"merged: {len(result['rows'])} finished runs ({_counts(result['rows'])})")
    print_stages(result)
    if result["missing"]:
        by: dict[Any, int] = {}
        for s, _ in result["missing"]:
            by[s] = by.get(s, 0) + 1
        print(f"not finished: {len(result['missing'])} runs ("
              + ", ".join(f"shard {s}: {k}" if s else f"{k}" for s, k in sorted(
                  by.items(), key=lambda x: str(x[0]))) + "); run those shards again, or "
              f"slamq run {args.config} to finish them here", file=sys.stderr)
    if result["summary"] is not None:
        print(f"summary: {result['results'].parent / 'summary.csv'}")
    if result["results"] is not None:
        print(f"results: {result['results']}")
    if result["report"] is not None:
        print(f"report {report_state(result)}: {result['report']}")
    return EXIT_OK


def _counts(rows: list[dict]) -> str:
    counts: dict[str, int] = {}
    for row in rows:
        counts[row["outcome"]] = counts.get(row["outcome"], 0) + 1
    return ", ".join(f"{n} {k}" for k, n in sorted(counts.items())) or "none"


def print_stages(result: dict) -> None:
    """One line per scoring stage (scores, GIFs, report): what it did, skipped and why.

    Examples
    --------
    >>> print_stages({"stages": [{"stage": "gifs", "done": 0, "message": "GIFs: none"}]})
    GIFs: none
    """
    for stage in result.get("stages") or []:
        print(stage["message"])


def report_state(result: dict) -> str:
    """``written``, or ``unchanged`` when the report stage skipped it.

    Examples
    --------
    >>> report_state({"stages": [{"stage": "report", "done": 0, "message": ""}]})
    'unchanged'
    """
    for stage in result.get("stages") or []:
        if stage["stage"] == "report" and not stage["done"]:
            return "unchanged"
    return "written"
