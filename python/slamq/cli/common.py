"""What every ``slamq`` command shares: exit codes, the one error line, the warning digest,
option helpers, and the check for optional extras.

Commands raise :class:`~slamq.errors.SlamqError` (or ``OSError``) for a failure that ends
the whole command; :func:`slamq.cli.main` turns it into one stderr line and exit code 2.
A failure of one input among many is printed with :func:`error_line` and counted by the
command, which goes on with the others.
"""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import logging
import sys
import threading
import time
from typing import IO, Any

from slamq.errors import SlamqError

EXIT_OK = 0
EXIT_ERROR = 1
EXIT_BAD_INPUT = 2
#: Array jobs: a shard with a run that is not ok, a merge with runs not finished.
EXIT_INCOMPLETE = 3

#: Optional extras: name -> the modules they bring.
EXTRAS = {
    "report": ("matplotlib", "PIL", "pandas"),
    "bags": ("rosbags",),
    "dask": ("distributed",),
}


def error_text(where: str, exc: BaseException | str) -> str:
    """The one line that says an input failed: ``slamq: error: FILE: reason``."""
    msg = " ".join(str(exc).split())
    if where and where not in msg:
        msg = f"{where}: {msg}"
    return f"slamq: error: {msg}"


def error_line(where: str, exc: BaseException | str) -> None:
    """Print :func:`error_text` on stderr."""
    print(error_text(where, exc), file=sys.stderr)


def exit_code(found: int, failed: int, unexpected: int, paths: Any) -> int:
    """The exit code of a command over many inputs: 1 on an unexpected error, 2 when some
    input failed or none was found (said on stderr), else 0."""
    if unexpected:
        return EXIT_ERROR
    if not found and not failed:
        error_line("", "no map found in " + ", ".join(map(str, paths)))
        return EXIT_BAD_INPUT
    return EXIT_BAD_INPUT if failed else EXIT_OK


def need_extra(extra: str, what: str) -> None:
    """Raise a :class:`SlamqError` with the install command when ``extra`` is missing.

    Examples
    --------
    >>> need_extra("report", "slamq report")   # installed here: nothing happens
    """
    # found, not imported: importing matplotlib alone takes about a second, and a command
    # imports what it uses when it uses it
    missing = [module for module in EXTRAS[extra]
               if importlib.util.find_spec(module) is None]
    if missing:
        raise SlamqError(f"{what} needs the '{extra}' extra ({', '.join(missing)} not "
                         f"installed): pip install 'slamq[{extra}]'")


def add_map_options(parser: argparse.ArgumentParser) -> None:
    """Every metric parameter of the table (:func:`slamq.params.add_param_options`), plus
    ``--unknown-value`` (shared by eval, batch, timeline)."""
    from slamq.params import add_param_options

    add_param_options(parser)
    add_unknown_value_option(parser)


def add_unknown_value_option(parser: argparse.ArgumentParser) -> None:
    """``--unknown-value`` (eval, batch, timeline through :func:`add_map_options`; compare)."""
    from slamq.params import SETTINGS

    SETTINGS.unknown_value.add_option(parser)


def add_table_output_options(parser: argparse.ArgumentParser) -> None:
    """``--json FILE`` / ``--csv FILE`` ('-': standard output) and ``--topic`` for maps in
    bags: the options of the commands that print one table row per map (eval, compare)."""
    for flag, kind in (("--json", "JSON"), ("--csv", "CSV")):
        parser.add_argument(flag, metavar="FILE",
                            help=f"write the results as {kind} ('-': to standard output, and "
                            "the table to standard error)")
    parser.add_argument("--topic", default=None,
                        help="for bags: the nav_msgs/OccupancyGrid topic (default /map)")


def add_compare_options(parser: argparse.ArgumentParser, prefix: str = "") -> None:
    """``--align``, ``--tolerance``, ``--max-distance`` of the ground-truth map comparison
    (docs/spec.md section 7); ``prefix`` ``"gt-"`` gives batch's ``--gt-align`` etc."""
    from slamq.params import SETTINGS

    dest = prefix.replace("-", "_")
    SETTINGS.compare_align.add_option(parser, f"--{prefix}align", dest=f"{dest}align")
    SETTINGS.tolerance.add_option(parser, f"--{prefix}tolerance", dest=f"{dest}tolerance",
                                  metavar="M")
    SETTINGS.max_distance.add_option(parser, f"--{prefix}max-distance",
                                     dest=f"{dest}max_distance", metavar="M")


def add_threads_option(parser: argparse.ArgumentParser) -> None:
    """``--threads`` (eval, compare, batch, timeline)."""
    from slamq.params import SETTINGS

    SETTINGS.threads.add_option(parser)


def add_verbosity_options(parser: argparse.ArgumentParser) -> None:
    """``-v/--verbose`` and ``-q/--quiet`` (every command has them)."""
    parser.add_argument("-v", "--verbose", action="count", default=0,
                        help="say more (debug messages, e.g. how each map was read)")
    parser.add_argument("-q", "--quiet", action="count", default=0,
                        help="say less: no warnings, progress or summary tables (errors and "
                        "results only)")


class Progress:
    """A rich progress bar on stderr (items/s and ETA), or nothing when not a terminal.

    ``label`` heads the bar, ``unit`` names the items (``"maps"``).
    """

    def __init__(self, label: str, unit: str, enabled: bool) -> None:
        self.unit = unit
        self.bar: Any | None = None
        self.task: Any = None
        if enabled:  # rich only when a bar may be drawn (-q: not imported at all)
            from rich.console import Console

            self.console = Console(stderr=True)
        if enabled and self.console.is_terminal:
            from rich.progress import (
                BarColumn,
                MofNCompleteColumn,
                Progress,
                TextColumn,
                TimeElapsedColumn,
                TimeRemainingColumn,
            )

            self.bar = Progress(
                TextColumn(f"[bold]{label}"),
                BarColumn(),
                MofNCompleteColumn(),
                TextColumn("{task.fields[rate]} " + unit + "/s"),
                TimeElapsedColumn(),
                TextColumn("ETA"),
                TimeRemainingColumn(),
                console=self.console,
                transient=False,
            )
        self.t0 = time.perf_counter()

    def __enter__(self) -> Progress:
        if self.bar is not None:
            self.bar.start()
            self.task = self.bar.add_task(self.unit, total=None, rate="-")
        return self

    def __exit__(self, *exc: Any) -> None:
        if self.bar is not None:
            self.bar.stop()

    def update(self, done: int, total: int) -> None:
        if self.bar is None:
            return
        dt = time.perf_counter() - self.t0
        rate = f"{done / dt:.1f}" if dt > 0 else "-"
        self.bar.update(self.task, completed=done, total=total, rate=rate)

    def line(self, text: str) -> None:
        """One stderr line that does not break the bar."""
        if self.bar is not None:
            self.bar.console.print(text, markup=False, highlight=False, soft_wrap=True)
        else:
            print(text, file=sys.stderr, flush=True)


class _LowerLevelFormatter(logging.Formatter):
    """``slamq: debug: ...`` like the ``slamq: warning:`` and ``slamq: error:`` lines."""

    def format(self, record: logging.LogRecord) -> str:
        return super().format(record).replace(
            f"slamq: {record.levelname}:", f"slamq: {record.levelname.lower()}:", 1)


def set_verbosity(level: int) -> None:
    """Route the ``slamq`` logger to stderr: debug messages at ``level >= 1``."""
    logger = logging.getLogger("slamq")
    for old in [h for h in logger.handlers if getattr(h, "slamq_cli", False)]:
        logger.removeHandler(old)  # bound to an earlier sys.stderr
    handler = logging.StreamHandler(sys.stderr)
    handler.setFormatter(_LowerLevelFormatter("slamq: %(levelname)s: %(message)s"))
    handler.slamq_cli = True  # type: ignore[attr-defined]
    logger.addHandler(handler)
    logger.setLevel(logging.DEBUG if level >= 1 else
                    logging.WARNING if level == 0 else logging.ERROR)


def stdout_console() -> Any:
    """A rich console on stdout (wide when stdout is not a terminal)."""
    from rich.console import Console

    console = Console()
    if not console.is_terminal:
        console = Console(width=160)
    return console


def cli_words(text: str) -> str:
    """A library message in the command line's words: a keyword of a spec parameter
    (``canonical_resolution=0.07``, ``align='search'``) becomes its option
    (``--canonical-resolution 0.07``, ``--align search``).

    Examples
    --------
    >>> cli_words("compare corners_canonical (canonical_resolution=0.07); pass align='search'")
    'compare corners_canonical (--canonical-resolution 0.07); pass --align search'
    """
    import re

    from slamq.params import PARAM_NAMES, SETTINGS

    known = set(PARAM_NAMES) | {s.name for s in SETTINGS.values()} | {"align"}

    def option(m: re.Match[str]) -> str:
        name, value = m.group(1), m.group(2).strip("'\"")
        return f"--{name.replace('_', '-')} {value}" if name in known else m.group(0)

    return re.sub(r"\b([a-z][a-z0-9_]*)=('[^']*'|\"[^\"]*\"|[\w.+-]+)", option, text)


class WarningDigest:
    """Python warnings (e.g. :class:`slamq.MapWarning`) as one stderr line each; a warning
    that repeats for other files (same text after the file name) is shown once and the other
    files are counted (each file once, however often it was loaded)."""

    def __init__(self, quiet: bool = False) -> None:
        self.files: dict[tuple[type, str], set[str]] = {}
        self.lock = threading.Lock()
        self.quiet = quiet

    def show(self, message: Warning | str, category: type, filename: str, lineno: int,
             file: IO[str] | None = None, line: str | None = None) -> None:
        text = cli_words(" ".join(str(message).split()))
        where, sep, reason = text.partition(": ")
        key = (category, reason if sep else text)
        with self.lock:
            seen = self.files.setdefault(key, set())
            first = not seen
            seen.add(where if sep else text)
        if first and not self.quiet:
            print(f"slamq: warning: {text}", file=sys.stderr)

    def summary(self) -> None:
        if self.quiet:
            return
        for (_, reason), files in self.files.items():
            if len(files) > 1:
                short = reason if len(reason) <= 70 else reason[:67] + "..."
                print(f"slamq: warning: the same for {len(files) - 1} more file(s): {short}",
                      file=sys.stderr)
