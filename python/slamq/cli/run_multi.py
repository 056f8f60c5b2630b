"""``slamq run CONFIG --shard I/N`` and ``--merge``: the array-job half of ``slamq run``."""

from __future__ import annotations

import argparse
import sys
from typing import Any, Callable

from slamq.cli.common import EXIT_INCOMPLETE, EXIT_OK
from slamq.errors import ParamError


def shard_or_merge(args: argparse.Namespace, progress: Callable[[dict], Any]) -> int:
    """Run one shard (nothing scored) or merge the finished runs; print where things are."""
    from slamq.runner import shards

    if args.partial and not args.merge:
        raise ParamError("--partial goes with --merge")
    if args.shard and (args.merge or args.scheduler or args.dry_run):
        raise ParamError("--shard runs one slice locally: not with --merge, --scheduler or "
                         "--dry-run")
    if args.shard:
        i, n = shards.parse_shard(args.shard, known=shards.recorded_shard_count(args.config))
        result = shards.run_shard(args.config, (i, n), retry_failed=args.retry_failed,
                                  progress=progress)
        rows = result["rows"]
        ran = [r for r in rows if not r.get("skipped")]
        found = [r for r in rows if r.get("skipped")]
        print(f"shard {i}/{n}: {len(rows)} runs: ran {len(ran)} ({_counts(ran)}), found "
              f"{len(found)} done ({_counts(found)}); record: {result['record']}")
        bad = [r for r in rows if r["outcome"] != "ok"]
        if bad:
            print(f"shard {i}/{n}: {len(bad)} run(s) not ok ({_counts(bad)}): see runs' "
                  f"logs; run them again with slamq run {args.config} --shard {i}/{n} "
                  "--retry-failed", file=sys.stderr)
            return EXIT_INCOMPLETE
        print(f"when every shard is done: slamq run {args.config} --merge")
        return EXIT_OK
    result = shards.merge(args.config)
    print(f"merged: {len(result['rows'])} finished runs ({_counts(result['rows'])})")
    print_stages(result)
    if result["summary"] is not None:
        print(f"summary: {result['results'].parent / 'summary.csv'}")
    if result["results"] is not None:
        print(f"results: {result['results']}")
    if result["report"] is not None:
        print(f"report {report_state(result)}: {result['report']}")
    if result["missing"]:
        by: dict[Any, int] = {}
        for s, _ in result["missing"]:
            by[s] = by.get(s, 0) + 1
        n = shards.recorded_shard_count(args.config)
        states = shards.shard_states(args.config, n) if n else {}

        def state(s: Any) -> str:
            if not s:
                return ""
            return f" ({states.get(int(str(s).split('/')[0]), 'missing')})"

        print(f"not finished: {len(result['missing'])} of "
              f"{len(result['missing']) + len(result['rows'])} runs ("
              + ", ".join(f"shard {s}{state(s)}: {k}" if s else f"{k}" for s, k in sorted(
                  by.items(), key=lambda x: str(x[0]))) + "); "
              + ("wait for the running shards, then merge again; " if any(
                  v.startswith("running") for v in states.values()) else "")
              + "run the others again (sbatch --array=K slurm-array.sh CONFIG N, or "
              f"slamq run {args.config} --shard K/N), or slamq run {args.config} to finish "
              "them here", file=sys.stderr)
        if not args.partial:
            print("slamq: the merge is partial (exit 3); --partial accepts that",
                  file=sys.stderr)
            return EXIT_INCOMPLETE
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
