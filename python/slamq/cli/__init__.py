"""The ``slamq`` command line: one module per command.

``slamq eval`` (:mod:`slamq.cli.eval`), ``compare`` (:mod:`~slamq.cli.compare`), ``verdict``
(:mod:`~slamq.cli.verdict`), ``batch``
(:mod:`~slamq.cli.batch`), ``summary`` (:mod:`~slamq.cli.summary`), ``report``
(:mod:`~slamq.cli.report`), ``ate`` / ``rpe`` (:mod:`~slamq.cli.trajectory`), ``timeline``
(:mod:`~slamq.cli.timeline`), ``synth`` (:mod:`~slamq.cli.synth`). Each module has
``add_parser(subparsers)`` and its command's entry ``handle(args)`` (``handle_ate`` /
``handle_rpe`` in :mod:`~slamq.cli.trajectory`); commands call library functions, never
:func:`main`. This module
is the one place that turns errors into exit codes: 0 success, 2 bad input (one stderr line
names the file and the reason), 1 anything unexpected, 130 Ctrl-C; and the one warning
digest (:class:`slamq.cli.common.WarningDigest`).
"""

from __future__ import annotations

import argparse
import importlib
import signal
import sys
import threading
import warnings
from collections.abc import Sequence

from slamq.cli.common import (
    EXIT_BAD_INPUT,
    EXIT_ERROR,
    WarningDigest,
    add_verbosity_options,
    error_line,
    set_verbosity,
)

#: The command modules, in ``--help`` order.
COMMANDS: tuple[str, ...] = (
    "slamq.cli.eval",
    "slamq.cli.compare",
    "slamq.cli.verdict",
    "slamq.cli.batch",
    "slamq.cli.summary",
    "slamq.cli.validate",
    "slamq.cli.report",
    "slamq.cli.trajectory",
    "slamq.cli.relations",
    "slamq.cli.timeline",
    "slamq.cli.run",
    "slamq.cli.synth",
)


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("slamq")
    except PackageNotFoundError:  # a source tree on sys.path, not installed
        return "unknown"


class _VersionAction(argparse.Action):
    """``--version``: print ``slamq VERSION`` and exit, looking the version up then."""

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values: object, option_string: str | None = None) -> None:
        print(f"slamq {_version()}")
        parser.exit()


def build_parser() -> argparse.ArgumentParser:
    """The full ``slamq`` argument parser."""
    parser = argparse.ArgumentParser(
        prog="slamq", description="Score 2D SLAM results (maps and trajectories).",
        epilog="Exit codes: 0 success, 2 bad input (one line names the file and the "
        "reason), 1 anything unexpected, 130 interrupted.",
    )
    # the version is looked up only when asked for (importlib.metadata costs every command
    # about 0.1 s)
    parser.add_argument("--version", action=_VersionAction, nargs=0,
                        help="show program's version number and exit")
    sub = parser.add_subparsers(dest="command", required=True)
    for name in COMMANDS:
        importlib.import_module(name).add_parser(sub)
    for command in sub.choices.values():
        add_verbosity_options(command)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``slamq`` command line; returns the exit code."""
    from slamq.errors import SlamqError

    args = build_parser().parse_args(argv)
    set_verbosity(args.verbose - args.quiet)
    digest = WarningDigest(quiet=args.quiet > 0)
    previous, warnings.showwarning = warnings.showwarning, digest.show
    # SIGTERM (a batch scheduler's time limit, `kill`) stops a command as Ctrl-C does: the
    # running SLAM programs' groups are stopped and finished work is kept
    term = (signal.signal(signal.SIGTERM, _interrupt)
            if threading.current_thread() is threading.main_thread() else None)
    try:
        return int(args.func(args))
    except KeyboardInterrupt:
        print("slamq: interrupted", file=sys.stderr)
        return 130
    except (SlamqError, OSError) as exc:
        error_line("", exc)
        return EXIT_BAD_INPUT
    except Exception as exc:  # noqa: BLE001 - last line of defence: one clear line
        error_line("", f"unexpected {type(exc).__name__}: {exc}")
        return EXIT_ERROR
    finally:
        if term is not None:
            signal.signal(signal.SIGTERM, term)
        warnings.showwarning = previous
        digest.summary()
        if argv is None:  # the program (not a caller in-process): the interpreter exits next
            _before_exit()


def _before_exit() -> None:
    """Freeze what the command left (``gc.freeze``): the interpreter's collections at exit
    then skip it, instead of walking every object of pandas, pyarrow and numpy (about 0.25 s
    of CPU after ``slamq report``). Objects are still freed by reference counting, the
    files written are closed; what the collector would have found in cycles is left to the
    operating system, which takes the whole process back a moment later anyway."""
    import gc

    gc.freeze()


def _interrupt(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


if __name__ == "__main__":
    sys.exit(main())
