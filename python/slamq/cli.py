"""The ``slamq`` command line: ``slamq eval | batch | summary | ate | rpe | report | timeline``.

``slamq eval`` lives here (it is the main job); every other command lives beside the code
it drives, in a module that exposes ``add_parser(subparsers)`` and is listed in
``_COMMAND_MODULES``. Exit codes: 0 success, 2 bad input (the message names the file and
the reason), 1 anything unexpected.
"""

from __future__ import annotations

import argparse
import importlib
import sys
import threading
import warnings
from collections.abc import Sequence
from typing import IO

#: Modules that each add one subcommand with ``add_parser(subparsers)``.
_COMMAND_MODULES: tuple[str, ...] = (
    "slamq.report.cli",
    "slamq.batch_cli",
    "slamq.trajectory_cli",
    "slamq.timeline",
)

EXIT_OK = 0
EXIT_ERROR = 1
EXIT_BAD_INPUT = 2


def add_metric_options(parser: argparse.ArgumentParser) -> None:
    """Add every SPEC parameter as an option (shared by eval, batch, timeline)."""
    from slamq.params import Params

    d = Params()
    g = parser.add_argument_group("metric parameters (SPEC.md sections 3-4)")
    g.add_argument("--log-threshold", type=float, default=d.log_threshold,
                   help="LoG structure threshold, fraction of 255*256 (default %(default)s)")
    g.add_argument("--min-dot-area", type=int, default=d.min_dot_area,
                   help="drop structure components smaller than this, cells (default %(default)s)")
    g.add_argument("--harris-k", type=float, default=d.harris_k,
                   help="Harris k (default %(default)s)")
    g.add_argument("--harris-quality", type=float, default=d.harris_quality,
                   help="corner mask: R > quality * max R (default %(default)s)")
    g.add_argument("--sweep-step", type=int, default=d.sweep_step,
                   help="enclosed areas: unknown value step, 1..256 (default %(default)s)")
    g.add_argument("--min-area", type=int, default=d.min_area,
                   help="enclosed areas: smallest counted region, cells (default %(default)s)")
    g.add_argument("--unknown-value", type=int, default=None,
                   help="treat pixels equal to this value as unknown, and nothing else")


def metric_kwargs(args: argparse.Namespace) -> dict:
    """The metric parameters from parsed options, as ``slamq.evaluate`` keywords."""
    return {
        "log_threshold": args.log_threshold,
        "min_dot_area": args.min_dot_area,
        "harris_k": args.harris_k,
        "harris_quality": args.harris_quality,
        "sweep_step": args.sweep_step,
        "min_area": args.min_area,
    }


def error_line(where: str, exc: BaseException) -> None:
    """Print one clear line for a failed input on stderr."""
    msg = str(exc)
    if where and where not in msg:
        msg = f"{where}: {msg}"
    print(f"slamq: error: {msg}", file=sys.stderr)


def _cmd_eval(args: argparse.Namespace) -> int:
    from slamq.errors import ParamError, SlamqError
    from slamq.maps import discover_maps
    from slamq.output import print_table, write_csv, write_json
    from slamq.params import Params
    from slamq.quality import evaluate

    try:
        Params(**metric_kwargs(args))
        if args.threads is not None and args.threads < 1:
            raise ParamError(f"--threads must be a positive integer, got {args.threads}")
    except ParamError as exc:
        error_line("", exc)
        return EXIT_BAD_INPUT
    failed = unexpected = 0
    sources, problems = discover_maps(args.paths)
    for where, reason in problems:
        error_line(where, reason)
        failed += 1
    results = []
    for src in sources:
        try:
            q = evaluate(
                src,
                curve=args.curve,
                verify=args.verify,
                threads=args.threads,
                unknown_value=args.unknown_value,
                **metric_kwargs(args),
            )
        except SlamqError as exc:
            error_line(str(src), exc)
            failed += 1
            continue
        except Exception as exc:  # noqa: BLE001 - a bug on one map must not cost the others
            error_line(str(src), RuntimeError(f"unexpected {type(exc).__name__}: {exc}"))
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
        error_line("", ValueError("no map found in " + ", ".join(map(str, args.paths))))
        return EXIT_BAD_INPUT
    return EXIT_BAD_INPUT if failed else EXIT_OK


def build_parser() -> argparse.ArgumentParser:
    """The full ``slamq`` argument parser."""
    parser = argparse.ArgumentParser(
        prog="slamq", description="Score 2D SLAM results (maps and trajectories)."
    )
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser(
        "eval",
        help="the three map metrics of one or more maps",
        description="Evaluate maps (YAML + image, or images; folders are searched "
        "recursively; an image named by a YAML beside it is evaluated once, through the YAML).",
    )
    p.add_argument("paths", nargs="+", help="map files or folders")
    p.add_argument("--json", metavar="FILE", help="write the results as JSON")
    p.add_argument("--csv", metavar="FILE", help="write the results as CSV")
    p.add_argument("--curve", action="store_true",
                   help="keep the enclosed-area curve over the unknown value")
    p.add_argument("--verify", action="store_true",
                   help="also run slamq.reference (slow) and fail on any difference")
    p.add_argument("--threads", type=int, default=None, help="cap on worker threads")
    add_metric_options(p)
    p.set_defaults(func=_cmd_eval)
    for name in _COMMAND_MODULES:
        importlib.import_module(name).add_parser(sub)
    return parser


class _WarningDigest:
    """Python warnings (e.g. :class:`slamq.MapWarning`) as one stderr line each; a warning
    that repeats for other files (same text after the file name) is shown once and the other
    files are counted (each file once, however often it was loaded)."""

    def __init__(self) -> None:
        self.files: dict[tuple[type, str], set[str]] = {}
        self.lock = threading.Lock()

    def show(self, message: Warning | str, category: type, filename: str, lineno: int,
             file: IO[str] | None = None, line: str | None = None) -> None:
        text = " ".join(str(message).split())
        where, sep, reason = text.partition(": ")
        key = (category, reason if sep else text)
        with self.lock:
            seen = self.files.setdefault(key, set())
            first = not seen
            seen.add(where if sep else text)
        if first:
            print(f"slamq: warning: {text}", file=sys.stderr)

    def summary(self) -> None:
        for (_, reason), files in self.files.items():
            if len(files) > 1:
                short = reason if len(reason) <= 70 else reason[:67] + "..."
                print(f"slamq: warning: the same for {len(files) - 1} more file(s): {short}",
                      file=sys.stderr)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``slamq`` command line; returns the exit code."""
    args = build_parser().parse_args(argv)
    outer = not isinstance(getattr(warnings.showwarning, "__self__", None), _WarningDigest)
    digest = _WarningDigest()
    if outer:  # a command that runs another (batch --report) keeps the outer digest
        previous, warnings.showwarning = warnings.showwarning, digest.show
    try:
        return int(args.func(args))
    except KeyboardInterrupt:
        return 130
    except Exception as exc:  # noqa: BLE001 - last line of defence: one clear line
        from slamq.errors import SlamqError

        error_line("", exc)
        return EXIT_BAD_INPUT if isinstance(exc, (SlamqError, OSError)) else EXIT_ERROR
    finally:
        if outer:
            warnings.showwarning = previous
            digest.summary()


if __name__ == "__main__":
    # run the importable module, not this __main__ copy, so that state such as the warning
    # digest is shared with commands that call slamq.cli.main again (batch --report)
    from slamq.cli import main as _main

    sys.exit(_main())
