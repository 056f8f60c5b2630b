"""``slamq run CONFIG``: run SLAM programs from a config file, then score and report them."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from slamq.cli.common import EXIT_OK


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Register ``slamq run``."""
    p = subparsers.add_parser(
        "run", help="run SLAM algorithms x sequences x iterations x parameters, then score",
        description="Run every (algorithm, parameter variant, sequence, iteration) of a YAML "
        "config, each in its own process group with a timeout; collect maps, trajectories "
        "and snapshots; score them with the batch engine; write runs.csv, results.jsonl, "
        "summary.csv (mean ± std over iterations, failure rate), GIFs and the report. "
        "Finished runs are skipped when run again.",
    )
    p.add_argument("config", help="run config (YAML), e.g. examples/mrpt.yaml")
    p.add_argument("--retry-failed", action="store_true",
                   help="run again the finished runs whose outcome was not ok")
    p.add_argument("--dry-run", action="store_true",
                   help="print the planned runs and their commands; run nothing")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="send each run to a Dask worker: a scheduler address "
                   "(tcp://host:8786), or 'dask' for DASK_SCHEDULER_ADDRESS or else a local "
                   "cluster of `parallel` worker processes (pip install 'slamq[dask]')")
    p.add_argument("--outputs", choices=("auto", "shared", "return"), default="auto",
                   help="with --scheduler: workers write runs into the shared output folder, "
                   "or return them as bytes; auto (default) = shared when a worker sees it")
    p.add_argument("--shard", metavar="I/N",
                   help="run only the I-th (0-based) of N round-robin slices of the planned "
                   "runs and score nothing (exit 3 when a run is not ok); 'N' alone takes I "
                   "from JOB_COMPLETION_INDEX or the Slurm array task; 'auto' also takes N "
                   "from the array, or from the output folder's earlier shards")
    p.add_argument("--merge", action="store_true",
                   help="run nothing: score every finished run (the shards') into one "
                   "results file, summary and report (a plain run merges too); exit 3 "
                   "when runs are not finished, naming each shard's state")
    p.add_argument("--partial", action="store_true",
                   help="with --merge: exit 0 although some runs are not finished")
    p.set_defaults(func=handle)


def handle(args: argparse.Namespace) -> int:
    """Run the config; print one line per run and where the results are."""
    from slamq.runner import process, runner

    # the runs' orphans are reparented to this process, which reaps them as they end (a
    # stopped run no longer waits for the container's init to reap them; see adopt_orphans)
    process.adopt_orphans()

    def progress(row: dict) -> None:
        print(f"{row['outcome']:<12} {row['algorithm']} {row['sequence']} #{row['iteration']}"
              f"  {row.get('wall', '-')} s  {row.get('reason', '')}", file=sys.stderr)

    if args.shard or args.merge or args.partial:
        from slamq.cli.run_multi import shard_or_merge

        return shard_or_merge(args, progress)
    backend = None
    if args.scheduler:
        from slamq.runner.distributed import dask_backend

        backend = dask_backend(args.scheduler, args.outputs)
    if not args.dry_run:
        from slamq.runner.config import load_config
        from slamq.runner.shards import check_no_live_shard

        check_no_live_shard(load_config(args.config))
    result = runner.run(args.config, retry_failed=args.retry_failed, dry_run=args.dry_run,
                        progress=progress, backend=backend)
    if args.dry_run:
        for row in result["rows"]:
            cmd = row.get("command")
            print(f"{row['outcome']:<10} {row['algorithm']} {row['sequence']} "
                  f"#{row['iteration']}: {cmd}")
        return EXIT_OK
    counts: dict[str, int] = {}
    for row in result["rows"]:
        counts[row["outcome"]] = counts.get(row["outcome"], 0) + 1
    found = sum(bool(row.get("skipped")) for row in result["rows"])
    print("runs: " + ", ".join(f"{n} {k}" for k, n in sorted(counts.items()))
          + f" (ran {len(result['rows']) - found}, found {found} done from an earlier run)")
    from slamq.cli.run_multi import print_stages, report_state

    print_stages(result)
    if result["summary"] is not None:
        print(f"summary: {result['results'].parent / 'summary.csv'}")
    print(f"results: {result['results']}")
    if result["report"] is not None:
        print(f"report {report_state(result)}: {result['report']}")
        for line in verdict_lines(result["report"]):
            print(line)
    return EXIT_OK


def verdict_lines(report: Any) -> list[str]:
    """One line per sequence from the report's ``verdict.json``: the program named best and
    on what basis, or that none was named and why.

    Examples
    --------
    >>> import json, pathlib, tempfile
    >>> d = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (d / "verdict.json").write_text(json.dumps([
    ...     {"sequence": "s", "best": "icp-slam", "basis": ["ate_rmse"], "confidence": "high"},
    ...     {"sequence": "t", "best": None, "basis": [], "confidence": "none: 2 maps"}]))
    >>> for line in verdict_lines(d / "index.html"):
    ...     print(line)
    best on s: icp-slam (by ate_rmse; high)
    best on t: none named (none: 2 maps)
    """
    import json
    from pathlib import Path

    path = Path(report)
    path = (path if path.is_dir() else path.parent) / "verdict.json"
    try:
        verdicts = json.loads(path.read_text())
    except (OSError, ValueError):
        return []
    lines = []
    for v in verdicts if isinstance(verdicts, list) else []:
        conf = str(v.get("confidence") or "").split(";")[0]
        if v.get("best"):
            basis = ", ".join(map(str, v.get("basis") or [])) or "the verdict"
            lines.append(f"best on {v.get('sequence')}: {v['best']} (by {basis}; {conf})")
        else:
            lines.append(f"best on {v.get('sequence')}: none named ({conf})")
    return lines

