"""``slamq verdict PATH...``: which of several maps of one place to trust, without ground
truth.

Follow it: :func:`handle` -> :func:`slamq.verdict.maps.maps_verdict` -> the three metrics
of each map (:func:`slamq.evaluate`), their agreement with each other and the defect
detectors (:func:`slamq.verdict.evidence.sequence_evidence`: :func:`slamq.agreement`,
:func:`slamq.metrics.defects.detect_defects`), and the rule of docs/spec.md section 9
(:func:`slamq.verdict.rule.sequence_verdict`), the one the report's verdict uses.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from typing import Any

from slamq.cli.common import add_threads_option, cli_words, error_line, exit_code


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Register ``slamq verdict``."""
    p = subparsers.add_parser(
        "verdict",
        help="which of several maps of one place to trust, without ground truth",
        description="Name the best of several maps of one place (different SLAM programs "
        "or settings), without ground truth: every map is laid over every other, maps the "
        "others do not confirm or that a defect detector flags are never named, corners "
        "only order the maps the others confirm equally on one grid (with --scans, each "
        "map's own scans order the maps corners cannot compare, on other grids or turned, "
        "and the tied ones where corners leave no clear winner), and the verdict "
        "abstains, saying why, when the evidence is weak (docs/spec.md section 9; how far "
        "it can be trusted: docs/validity.md). Folders are searched recursively as slamq "
        "eval does.",
    )
    p.add_argument("paths", nargs="+", help="map files (YAML + image, or images) or folders")
    p.add_argument("--json", metavar="FILE",
                   help="write the verdict and the evidence as JSON ('-': standard output)")
    p.add_argument("--no-defects", action="store_true",
                   help="agreement alone, without the defect detectors")
    p.add_argument("--scans", metavar="RECORDING",
                   help="the recording the maps were built from (CARMEN log, MRPT rawlog or "
                   "bag with laser scans); with --trajectory, each map is also scored "
                   "against its own scans, which can decide between two maps")
    p.add_argument("--trajectory", metavar="FILE", action="append",
                   help="the trajectory of the run that made each map, in the order the "
                   "maps are given (once per map; map files only, not folders)")
    add_threads_option(p)
    p.set_defaults(func=handle)


def handle(args: argparse.Namespace) -> int:
    """Score every map found, then the verdict; a bad map is one error line and takes no
    part, the others are still judged."""
    from slamq.errors import ParamError
    from slamq.params import check_threads
    from slamq.sources.walk import discover_maps
    from slamq.verdict.maps import maps_verdict
    from slamq.verdict.rule import verdict_sentence

    check_threads(args.threads, "--threads")
    if (args.scans is None) != (args.trajectory is None):
        raise ParamError("--scans and --trajectory go together")
    sources, problems = discover_maps(args.paths)
    if args.trajectory is not None and len(args.trajectory) != len(sources):
        raise ParamError(f"{len(args.trajectory)} --trajectory for {len(sources)} maps "
                         "(give one per map, in the order of the maps)")
    for where, reason in problems:
        error_line(where, reason)
    result = maps_verdict(sources, defects=not args.no_defects, threads=args.threads,
                          scans=args.scans, trajectories=args.trajectory)
    for where, reason in result["errors"]:
        error_line(where, reason)
    failed = len(problems) + len(result["errors"])
    out = sys.stderr if args.json == "-" else sys.stdout
    if result["verdict"] is not None and not args.quiet:
        _print(result, out)
        print(verdict_sentence(result["verdict"]), file=out)
    if args.json and result["verdict"] is not None:
        text = json.dumps(_jsonable({k: result[k] for k in ("verdict", "evidence", "maps")}),
                          indent=1, allow_nan=False)
        if args.json == "-":
            print(text)
        else:
            with open(args.json, "w", encoding="utf-8") as f:
                f.write(text + "\n")
    return exit_code(len(result["maps"]), failed, 0, args.paths)


def _jsonable(x: Any) -> Any:
    """Nested dicts and lists with every leaf through :func:`slamq.results.columns.json_value`
    (NaN -> null: an unplaced map has no support)."""
    from slamq.results.columns import json_value

    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    return json_value(x)


def _fmt(x: Any, digits: int = 2) -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "-"
    return f"{x:.{digits}f}" if isinstance(x, float) else str(x)


def _print(result: dict[str, Any], out: Any) -> None:
    """The maps in the verdict's order: rank, support, completeness, crossing share, the
    path's split crossing share (docs/spec.md 7e), of the beams with which its halves meet
    each other's walls the share that cross them (``halves``, docs/spec.md section 9), how
    much shorter the map's path is than another's at most (7d), corners, flags
    ("superposed (the building's)": lifted by docs/spec.md section 9)."""
    from slamq.verdict.rule import halves_misses, shared_directions, superposed_separations

    v, ev = result["verdict"], result["evidence"]
    info = ev["algorithms"] if ev else {}
    building = shared_directions(info, ev)
    halves = halves_misses(info)
    rows = [("rank", "map", "support", "complete", "crossing", "split", "halves", "short",
             "corners", "canonical", "flags")]
    order = list(v["ranking"]) + sorted(set(result["maps"]) - set(v["ranking"]))
    for i, name in enumerate(order, 1):
        e = info.get(name, {})
        kinds = sorted({d["kind"] for ds in e.get("defects", {}).values() for d in ds})
        if "superposed" in kinds and name in building \
                and set(superposed_separations(e)) <= set(building[name]):
            kinds[kinds.index("superposed")] = "superposed (the building's)"
        if e and not e.get("placed", True):
            kinds.insert(0, "not placed")
        rank = str(i) if name in v["ranking"] else "-"
        rows.append((rank, name, _fmt(e.get("support")), _fmt(e.get("completeness")),
                     _fmt(e.get("scan_crossing"), 3), _fmt(e.get("scan_split"), 3),
                     _fmt(halves.get(name), 3),
                     _fmt(e.get("shortfall"), 3),
                     _fmt(result["maps"][name].get("corners"), 0),
                     _fmt(result["maps"][name].get("corners_canonical"), 0),
                     ", ".join(kinds) or "-"))
    widths = [max(len(r[c]) for r in rows) for c in range(len(rows[0]))]
    for r in rows:
        print("  ".join(cell.ljust(w) for cell, w in zip(r, widths)).rstrip(), file=out)
    for w in v["warnings"]:
        print(f"slamq: note: {cli_words(w)}", file=out)
