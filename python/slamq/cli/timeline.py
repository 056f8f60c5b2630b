"""``slamq timeline BAG --out DIR``: the map metrics of every map in a bag over time, PNG
frames, a GIF and a plot (:func:`slamq.report.timeline.timeline`)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from slamq.cli.common import (
    EXIT_BAD_INPUT,
    EXIT_OK,
    add_map_options,
    add_threads_option,
    error_line,
    need_extra,
)


def add_parser(subparsers: Any) -> None:
    """Register ``slamq timeline``."""
    p = subparsers.add_parser(
        "timeline",
        help="map metrics over time from the maps in a ROS bag, with frames and a GIF",
        description="Evaluate every N-th map a SLAM run published in a ROS1/ROS2/MCAP bag "
        "(and the last one); write metrics.jsonl, metrics.csv, PNG frames, timeline.gif "
        "and metrics.png into --out.",
    )
    p.add_argument("bag", help="a .bag, .db3 or .mcap file, or a ROS2 bag folder")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder (created)")
    p.add_argument("--every", type=int, default=1, metavar="N",
                   help="evaluate maps 0, N, 2N, ... and the last (default %(default)s)")
    p.add_argument("--topic", default="/map",
                   help="nav_msgs/OccupancyGrid topic (default %(default)s); "
                   "<topic>_updates patches are applied")
    p.add_argument("--max-size", type=int, default=512, metavar="PX",
                   help="longest side of frames and GIF in pixels (default %(default)s)")
    p.add_argument("--duration-ms", type=int, default=200,
                   help="GIF frame time (default %(default)s)")
    p.add_argument("--no-frames", action="store_true", help="do not write PNG frames")
    add_threads_option(p)
    add_map_options(p)
    p.set_defaults(func=handle)


def handle(args: argparse.Namespace) -> int:
    """Evaluate the bag's maps over time; write the files; print one row per map."""
    from slamq.params import params_from_args
    from slamq.report.timeline import timeline

    need_extra("report", "slamq timeline")
    need_extra("bags", "slamq timeline")

    if args.every < 1:
        error_line("", f"--every must be >= 1, got {args.every}")
        return EXIT_BAD_INPUT
    if args.max_size < 1:
        error_line("", f"--max-size must be >= 1, got {args.max_size}")
        return EXIT_BAD_INPUT
    kwargs: dict[str, Any] = params_from_args(args).to_dict()
    if args.unknown_value is not None:
        kwargs["unknown_value"] = args.unknown_value
    if args.threads is not None:
        kwargs["threads"] = args.threads
    rows = timeline(args.bag, args.out, every=args.every, topic=args.topic,
                    max_size=args.max_size, duration_ms=args.duration_ms,
                    frames=not args.no_frames, **kwargs)
    out = Path(args.out)
    print(f"{len(rows)} maps from {args.bag} ({args.topic}) -> {out}/")
    print(f"{'index':>6} {'time s':>9} {'occupied':>9} {'corners':>8} {'enclosed':>8}")
    for r in rows:
        frac = r["occupied_fraction"]
        frac_s = "nan" if frac is None else f"{frac:.4f}"
        print(f"{r['index']:>6} {r['elapsed']:>9.2f} {frac_s:>9} {r['corners']:>8} "
              f"{r['enclosed_areas']:>8}")
    return EXIT_OK
