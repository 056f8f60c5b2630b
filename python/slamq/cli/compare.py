"""``slamq compare EST... --gt GT``: maps scored against a ground-truth map (docs/spec.md
section 7).

Follow one map: :func:`run` -> :func:`slamq.compare` (python/slamq/metrics/compare.py) ->
``slamq._core.compare`` (rust/src/bindings/comparison.rs) -> rust/src/compare/ (edt/, icp.rs).
"""

from __future__ import annotations

import argparse
import csv
import json
import re
import sys
from pathlib import Path
from typing import IO, Any

from slamq.cli.common import (
    add_compare_options,
    add_table_output_options,
    add_threads_option,
    add_unknown_value_option,
    error_line,
    exit_code,
)
from slamq.cli.common import error_text as _error_text

#: The table's columns: (key, heading, format).
TABLE = (
    ("precision", "precision", "{:.3f}"), ("recall", "recall", "{:.3f}"),
    ("f1", "F1", "{:.3f}"), ("iou", "IoU", "{:.3f}"), ("ne", "NE (m)", "{:.3f}"),
    ("reverse", "reverse (m)", "{:.3f}"), ("chamfer", "chamfer (m)", "{:.3f}"),
    ("coverage", "coverage", "{:.3f}"), ("dx", "dx (m)", "{:+.3f}"), ("dy", "dy (m)", "{:+.3f}"),
    ("dyaw", "dyaw (deg)", "{:+.2f}"), ("icp_rms", "ICP RMS (m)", "{:.3f}"),
)


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Register ``slamq compare``."""
    p = subparsers.add_parser(
        "compare",
        help="score maps against a ground-truth map (aligned: precision, recall, F1, IoU, "
        "NE, chamfer, coverage)",
        description="Score maps against a ground-truth map (docs/spec.md section 7): each "
        "estimate is placed by the frames of the map files, aligned by trimmed ICP, "
        "resampled onto the ground truth's grid, and compared cell by cell. Folders are "
        "searched recursively (the ground-truth map itself is skipped).",
    )
    p.add_argument("paths", nargs="+", help="estimated maps (YAML, images, bags) or folders")
    p.add_argument("--gt", required=True, metavar="GT",
                   help="the ground-truth map (YAML + image, image, or bag)")
    add_compare_options(p)
    from slamq.params import SETTINGS

    SETTINGS.occupied_threshold.add_option(p, metavar="P")
    add_table_output_options(p)
    p.add_argument("--overlay", metavar="DIR",
                   help="write one PNG per map: the aligned estimate over the ground truth, "
                   "matched walls green, missing walls red, ghost walls blue")
    add_unknown_value_option(p)
    add_threads_option(p)
    p.set_defaults(func=handle)


def handle(args: argparse.Namespace) -> int:
    """Compare every map found with the ground truth; one error line per bad map."""
    from slamq.errors import ParamError, SlamqError
    from slamq.metrics.compare import compare
    from slamq.params import check_threads
    from slamq.sources import load_map
    from slamq.sources.walk import discover_maps

    check_threads(args.threads, "--threads")
    if args.json == "-" and args.csv == "-":
        raise ParamError("--json - and --csv - cannot both write to standard output")
    gt = load_map(args.gt, unknown_value=args.unknown_value, topic=args.topic)
    sources, problems = discover_maps(args.paths)
    gt_path = Path(args.gt).resolve()
    sources = [s for s in sources if s.resolve() != gt_path]
    failed = unexpected = 0
    for where, reason in problems:
        error_line(where, reason)
        failed += 1
    overlay = Path(args.overlay) if args.overlay else None
    if overlay is not None:
        overlay.mkdir(parents=True, exist_ok=True)
    results = []
    names: set[str] = set()
    for src in sources:
        try:
            est = load_map(src, unknown_value=args.unknown_value, topic=args.topic)
            c = compare(est, gt, tolerance=args.tolerance, align=args.align,
                        max_distance=args.max_distance,
                        occupied_threshold=args.occupied_threshold,
                        cells=overlay is not None, threads=args.threads)
            if overlay is not None:
                from slamq.report.comparison import write_comparison_png

                write_comparison_png(overlay / _png_name(src, gt_path, names), c)
        except SlamqError as exc:
            print(_error_text(str(src), exc), file=sys.stderr)
            failed += 1
            continue
        except Exception as exc:  # noqa: BLE001 - a bug on one map must not cost others
            print(_error_text(str(src), f"unexpected {type(exc).__name__}: {exc}"),
                  file=sys.stderr)
            unexpected += 1
            continue
        if c.note and not args.quiet:
            hint = "; use --align search (or auto)" if "fits better" in c.note else ""
            print(f"slamq: warning: {src}: {c.note}{hint}", file=sys.stderr)
        results.append(c)
    to_stdout = "-" in (args.json, args.csv)
    if results and not args.quiet:
        print_comparisons(results, file=sys.stderr if to_stdout else sys.stdout)
    rows = [c.to_dict() for c in results]
    if args.json:
        _write(args.json, lambda fh: json.dump(_clean(rows), fh, indent=1))
    if args.csv:
        _write(args.csv, lambda fh: _csv(fh, rows))
    return exit_code(len(results), failed, unexpected, args.paths)


def _png_name(src: Path, gt: Path, taken: set[str]) -> str:
    stem = re.sub(r"[^A-Za-z0-9_.-]+", "_", f"{src.parent.name}_{src.stem}_vs_{gt.stem}")
    name, k = f"{stem}.png", 1
    while name in taken:
        k += 1
        name = f"{stem}_{k}.png"
    taken.add(name)
    return name


def _clean(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    from slamq.results.columns import json_value

    return [{k: json_value(v) for k, v in r.items()} for r in rows]


def _safe_cell(value: Any) -> Any:
    """A text cell a spreadsheet would run as a formula, prefixed with ``'``."""
    if isinstance(value, str) and value[:1] in ("=", "+", "-", "@", "\t", "\r"):
        return "'" + value
    return value


def _csv(fh: IO[str], rows: list[dict[str, Any]]) -> None:
    if not rows:
        return
    writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
    writer.writeheader()
    for r in _clean(rows):
        writer.writerow({k: _safe_cell(v) for k, v in r.items()})


def _write(target: str, write: Any) -> None:
    if target == "-":
        write(sys.stdout)
        return
    with open(target, "w", newline="", encoding="utf-8") as fh:
        write(fh)


def print_comparisons(results: list[Any], file: IO[str] = sys.stdout) -> None:
    """A fixed-width table, one row per compared map."""
    from slamq.results.table import short_names

    names = short_names([c.estimate for c in results])
    head = ["map", *(h for _, h, _ in TABLE)]
    rows = [[names[c.estimate], *(_fmt(getattr(c, k), f) for k, _, f in TABLE)]
            for c in results]
    widths = [max(len(r[i]) for r in [head, *rows]) for i in range(len(head))]
    lines = ["  ".join(h.ljust(wd) if i == 0 else h.rjust(wd)
                       for i, (h, wd) in enumerate(zip(row, widths)))
             for row in [head, *rows]]
    gt = results[0].ground_truth
    used = sorted({c.align for c in results})
    align = used[0] if len(used) == 1 else "/".join(used) + " (see the warnings)"
    print(f"against {gt} (align {align}, tolerance {results[0].tolerance:.3g} m)", file=file)
    print("\n".join(lines), file=file)


def _fmt(value: Any, fmt: str) -> str:
    if value is None or (isinstance(value, float) and value != value):
        return "-"
    return fmt.format(value)
