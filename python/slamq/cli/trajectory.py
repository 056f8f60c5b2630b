"""``slamq ate`` and ``slamq rpe``: trajectory error of one or more estimates.

Each estimate is compared with the one ground truth and gets its own row (as evo does);
with ``--runs`` the estimates are repeated runs of one system and the mean and the sample
standard deviation of their RMSE are printed too (as ``slamq summary`` does; the JSON has
both ``rmse_std`` (population, as :class:`slamq.metrics.ate.RunsResult.std`) and
``rmse_std_sample``). A paired pose log (``slam_x ... gt_x`` columns in one CSV, as
slam_comparison_tools writes) is its own ground truth: ``slamq ate LOG.csv``.

Alignment differs from evo's defaults: ``slamq ate`` aligns with ``se2`` unless told
otherwise (``evo_ape`` aligns nothing without ``-a``); ``slamq rpe`` aligns nothing, as
``evo_rpe``. Every printed result says its alignment.

``--interpolate`` pairs each ground-truth pose with the estimate interpolated at its time,
``--time-offset auto`` searches the clock offset of each estimate and prints it
(docs/spec.md 6b); without them the association is evo's and the numbers are evo's.
Exit codes: 0 success, 2 bad input (one stderr line names the file and the reason).
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

from slamq.cli.common import EXIT_BAD_INPUT, EXIT_OK, error_line

__all__ = ["add_parser"]

_STATS = ("rmse", "mean", "median", "std", "min", "max")


def _common_options(p: argparse.ArgumentParser, command: str) -> None:
    from slamq.params import SETTINGS

    p.add_argument("gt", metavar="GT",
                   help="ground-truth trajectory (file or bag), or a paired pose log "
                   "(slam_x ... gt_x columns) that holds both")
    p.add_argument("est", metavar="EST", nargs="*",
                   help="estimated trajectories (default: the estimate columns of a paired "
                   "pose log GT)")
    p.add_argument("--runs", action="store_true",
                   help="the estimates are repeated runs of one system: also print the RMSE "
                   "mean and sample std over them (default: one row per file, as evo)")
    p.add_argument("--by-index", action="store_true",
                   help="accept tables without a time column, pairing poses by row number "
                   "(refused otherwise)")
    SETTINGS[f"{command}_align"].add_option(p, "--align", "-a", dest="align")
    SETTINGS.max_dt.add_option(p, metavar="S")
    SETTINGS.offset.add_option(p, metavar="S")
    p.add_argument("--time-offset", metavar="auto|S", default=None, type=_time_offset,
                   help="seconds added to the estimate timestamps, or 'auto': the offset "
                   "within +-MAX_OFFSET minimising the aligned ATE RMSE (printed; replaces "
                   "--offset; best with --interpolate)")
    p.add_argument("--max-offset", metavar="S", type=float, default=None,
                   help="bound of the --time-offset auto search, seconds either way "
                   "(default 1.0)")
    p.add_argument("--interpolate", action="store_true",
                   help="pair each ground-truth pose with the estimate interpolated at its "
                   "time (linear position, slerp) instead of the nearest pose within "
                   "--max-dt")
    p.add_argument("--max-gap", metavar="S", type=float, default=None,
                   help="with --interpolate: largest time between the two estimate poses "
                   "interpolated between (default 0.5)")
    SETTINGS.trajectory_format.add_option(p, "--format", dest="format")
    p.add_argument("--columns", metavar="MAP", default=None,
                   help="table columns, 'role=name,...' or positional 't,x,y,yaw' "
                   "(roles t x y z yaw qw qx qy qz), for GT and EST")
    p.add_argument("--gt-columns", metavar="MAP", default=None,
                   help="table columns of GT when they differ from --columns "
                   "(e.g. t=timestamp_sec,x=gt_x,y=gt_y)")
    p.add_argument("--topic", default=None, help="bag topic of the estimates")
    p.add_argument("--gt-topic", default=None, help="bag topic of the ground truth")
    SETTINGS.unsorted.add_option(p)
    p.add_argument("--json", metavar="FILE", help="write the results as JSON")
    p.add_argument("--per-pose", action="store_true",
                   help="include the per-pose errors in the JSON")


def _time_offset(value: str) -> float | str:
    """``auto`` or a finite number of seconds (argparse type of ``--time-offset``)."""
    if value == "auto":
        return value
    try:
        x = float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"'auto' or seconds, not {value!r}") from None
    if not math.isfinite(x):
        raise argparse.ArgumentTypeError(f"must be finite, not {value!r}")
    return x


def _sync_options(args: argparse.Namespace) -> dict:
    """The association keywords of ``slamq.ate`` / ``slamq.rpe`` from the options."""
    kw: dict = {"max_dt": args.max_dt, "offset": args.offset}
    if args.time_offset is not None:
        kw["offset"] = args.time_offset
    if args.interpolate:
        kw["interpolate"] = True
    if args.max_gap is not None:
        kw["max_gap"] = args.max_gap
    if args.max_offset is not None:
        kw["max_offset"] = args.max_offset
    return kw


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Register ``slamq ate`` and ``slamq rpe``."""
    p = subparsers.add_parser(
        "ate",
        help="absolute trajectory error (RMSE ...) of estimates against ground truth",
        description="Absolute trajectory error (docs/spec.md section 6): associate poses by "
        "timestamp, align, and report RMSE, mean, median, std, min, max and n per "
        "estimate; for several estimates also the RMSE mean and std over the runs. "
        "Equal to evo_ape for se3 (-a), sim3 (-as), origin and none.",
    )
    _common_options(p, "ate")
    p.set_defaults(func=handle_ate)

    p = subparsers.add_parser(
        "rpe",
        help="relative pose error of estimates against ground truth",
        description="Relative pose error as evo_rpe: pose pairs DELTA frames or metres "
        "apart, translation (m) or rotation angle error of the relative motion.",
    )
    _common_options(p, "rpe")
    p.add_argument("--delta", type=float, default=1,
                   help="pair distance in --unit (default %(default)s)")
    p.add_argument("--unit", choices=("frames", "m"), default="frames",
                   help="unit of --delta (default %(default)s)")
    p.add_argument("--relation", choices=("trans", "angle_deg", "angle_rad"),
                   default="trans", help="error of the relative pose (default %(default)s)")
    p.add_argument("--pairs-from", choices=("est", "gt"), default="est",
                   help="whose path length picks the pairs for --unit m (default est)")
    p.set_defaults(func=handle_rpe)


def _load(path: str, args: argparse.Namespace, gt: bool):
    from slamq.sources.trajectories import load_trajectory, paired_mappings

    columns = args.gt_columns if (gt and args.gt_columns) else args.columns
    if columns is None and args.format in (None, "csv"):
        # a paired pose log: the same column detection as slamq batch
        mappings = paired_mappings(path)
        if mappings is not None:
            columns = mappings[1] if gt else mappings[0]
    topic = args.gt_topic if gt else args.topic
    return load_trajectory(path, format=args.format, columns=columns, topic=topic,
                           unsorted=args.unsorted, by_index=args.by_index)


def _fmt(x: float) -> str:
    return f"{x:.6f}" if math.isfinite(x) else str(x)


def _print_table(results: list, unit: str) -> None:
    rows = [[r.est_source, str(r.n), *(_fmt(getattr(r, k)) for k in _STATS)]
            for r in results]
    head = ["estimate", "n", *(f"{k} ({unit})" for k in _STATS)]
    widths = [max(len(h), *(len(row[i]) for row in rows)) for i, h in enumerate(head)]
    line = "  ".join(h.ljust(w) if i == 0 else h.rjust(w)
                     for i, (h, w) in enumerate(zip(head, widths)))
    print(line)
    for row in rows:
        print("  ".join(c.ljust(w) if i == 0 else c.rjust(w)
                        for i, (c, w) in enumerate(zip(row, widths))))


def _run(args: argparse.Namespace, metric: str) -> int:
    from slamq.errors import SlamqError
    from slamq.metrics.ate import ate, rpe

    if args.time_offset is not None and args.offset != 0:
        error_line("", "--offset and --time-offset both set the estimate's time offset; "
                   "give one")
        return EXIT_BAD_INPUT
    try:
        gt = _load(args.gt, args, gt=True)
    except (SlamqError, OSError) as exc:
        error_line(args.gt, exc)
        return EXIT_BAD_INPUT
    results, failed = [], []
    for path in args.est or [args.gt]:
        try:
            est = _load(path, args, gt=False)
            if metric == "ate":
                r = ate(gt, est, align=args.align, **_sync_options(args))
            else:
                r = rpe(gt, est, align=args.align, delta=args.delta, unit=args.unit,
                        relation=args.relation, pairs_from=args.pairs_from,
                        **_sync_options(args))
        except (SlamqError, OSError) as exc:
            error_line(path, exc)
            failed.append({"file": path, "error": str(exc)})
            continue
        results.append(r)
    unit = {"trans": "m", "angle_deg": "deg", "angle_rad": "rad"}[
        getattr(args, "relation", "trans")]
    summary = None
    if results:
        title = f"{metric.upper()} vs {gt.source} (align {args.align}"
        if metric == "rpe":
            d = args.delta
            title += f", delta {int(d) if args.unit == 'frames' else d} {args.unit}"
        if args.interpolate:
            title += ", interpolated"
        print(title + ")")
        _print_table(results, unit)
        if args.time_offset == "auto":
            for r in results:
                print(f"time offset found for {r.est_source}: {r.params['offset']:+.4f} s "
                      f"(added to its timestamps; search +-"
                      f"{r.params['offset_search']['max_offset']} s)")
        if len(results) > 1 and not args.runs:
            print("one row per estimate; --runs if they are repeated runs of one system "
                  "(RMSE mean and std over them)")
        if len(results) > 1 and args.runs:
            import numpy as np

            rmse = np.array([r.rmse for r in results])
            summary = {
                "runs": len(results),
                "rmse_mean": float(rmse.mean()),
                "rmse_std": float(rmse.std()),
                "rmse_std_sample": float(rmse.std(ddof=1)),
            }
            print(  # sample std, as slamq summary prints by default
                f"RMSE over {len(results)} runs (align {args.align}): "
                f"{summary['rmse_mean']:.6f} \u00b1 "
                f"{summary['rmse_std_sample']:.6f} {unit} (sample std; population std "
                f"{summary['rmse_std']:.6f})"
            )
    if args.json:
        doc = {
            "metric": metric,
            "align": args.align,
            "groundtruth": gt.source,
            "results": [r.to_dict(errors=args.per_pose) for r in results],
            "summary": summary,
            "failed": failed,
        }
        try:
            Path(args.json).write_text(json.dumps(doc, indent=2) + "\n")
        except OSError as exc:
            error_line(args.json, exc)
            return EXIT_BAD_INPUT
    return EXIT_BAD_INPUT if failed else EXIT_OK


def handle_ate(args: argparse.Namespace) -> int:
    return _run(args, "ate")


def handle_rpe(args: argparse.Namespace) -> int:
    return _run(args, "rpe")
