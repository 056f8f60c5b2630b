"""``slamq relations``: the relations error (Kümmerle et al. 2009) of one or more estimates.

Each estimate gets one row with the statistics the published tables give (Hess et al. 2016,
Table II): absolute translational error (m) and squared (m^2), absolute rotational (deg)
and squared (deg^2), each as mean +- std, the maxima, and how many relations were placed
on the estimate (docs/spec.md 6a).
Exit codes: 0 success, 2 bad input (one stderr line names the file and the reason).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from slamq.cli.common import EXIT_BAD_INPUT, EXIT_OK, error_line

__all__ = ["add_parser", "handle"]


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Register ``slamq relations``."""
    from slamq.params import SETTINGS

    p = subparsers.add_parser(
        "relations",
        help="relations error (Kümmerle et al. 2009) of estimates against a relations file",
        description="Relations error as Kümmerle et al. 2009 define it (docs/spec.md 6a): "
        "for each relation (t1, t2, motion) of --relations, the estimate's motion between "
        "its poses at t1 and t2 against it; translational (m, m^2) and rotational (deg, "
        "deg^2) error, absolute and squared mean +- std, and the maxima.",
    )
    p.add_argument("est", metavar="EST", nargs="+", help="estimated trajectories")
    p.add_argument("--relations", "-r", metavar="FILE", required=True,
                   help="relations file: 't1 t2 x y z roll pitch yaw' per line")
    p.add_argument("--interpolate", action="store_true",
                   help="place a relation stamp between the two neighbouring poses when no "
                   "pose is at it (default: only poses at the stamp)")
    p.add_argument("--max-gap", metavar="S", type=float, default=None,
                   help="with --interpolate: largest time between the two poses "
                   "interpolated between (default 0.5)")
    p.add_argument("--stamp-tol", metavar="S", type=float, default=None,
                   help="largest difference of a stamp and a pose's timestamp that counts as "
                   "that pose (default 1e-05)")
    SETTINGS.trajectory_format.add_option(p, "--format", dest="format")
    p.add_argument("--columns", metavar="MAP", default=None,
                   help="table columns, 'role=name,...' or positional 't,x,y,yaw'")
    p.add_argument("--topic", default=None, help="bag topic of the estimates")
    SETTINGS.unsorted.add_option(p)
    p.add_argument("--json", metavar="FILE", help="write the results as JSON")
    p.add_argument("--per-relation", action="store_true",
                   help="include the per-relation errors in the JSON")
    p.set_defaults(func=handle)


def _pm(mean: float, std: float, digits: int) -> str:
    return f"{mean:.{digits}f} \u00b1 {std:.{digits}f}"


def _print_table(results: list) -> None:
    head = ["estimate", "n", "unplaced", "abs trans (m)", "sq trans (m^2)", "max (m)",
            "abs rot (deg)", "sq rot (deg^2)", "max (deg)"]
    rows = [[r.est_source, str(r.n), str(r.n_unplaced),
             _pm(r.trans_abs_mean, r.trans_abs_std, 4), _pm(r.trans_sq_mean, r.trans_sq_std, 4),
             f"{r.trans_max:.4f}", _pm(r.rot_abs_mean, r.rot_abs_std, 3),
             _pm(r.rot_sq_mean, r.rot_sq_std, 3), f"{r.rot_max:.3f}"] for r in results]
    widths = [max(len(h), *(len(row[i]) for row in rows)) for i, h in enumerate(head)]
    for row in [head, *rows]:
        print("  ".join(c.ljust(w) if i == 0 else c.rjust(w)
                        for i, (c, w) in enumerate(zip(row, widths))))


def handle(args: argparse.Namespace) -> int:
    """Run ``slamq relations``."""
    from slamq.errors import SlamqError
    from slamq.metrics.relations import relations
    from slamq.sources.relations import read_relations
    from slamq.sources.trajectories import load_trajectory

    try:
        rel = read_relations(args.relations)
    except (SlamqError, OSError) as exc:
        error_line(args.relations, exc)
        return EXIT_BAD_INPUT
    options: dict = {"interpolate": args.interpolate}
    if args.max_gap is not None:
        options["max_gap"] = args.max_gap
    if args.stamp_tol is not None:
        options["stamp_tol"] = args.stamp_tol
    results, failed = [], []
    for path in args.est:
        try:
            est = load_trajectory(path, format=args.format, columns=args.columns,
                                  topic=args.topic, unsorted=args.unsorted)
            results.append(relations(est, rel, **options))
        except (SlamqError, OSError) as exc:
            error_line(path, exc)
            failed.append({"file": path, "error": str(exc)})
    if results:
        print(f"relations error vs {rel.source} ({len(rel)} relations"
              + (", interpolated" if args.interpolate else "") + "; mean \u00b1 std)")
        _print_table(results)
        for r in results:
            notes = []
            if r.n_unplaced:
                notes.append(f"{r.n_unplaced} relations not placed"
                             + ("" if args.interpolate else " (--interpolate may place them)"))
            if r.n_interpolated:
                notes.append(f"{r.n_interpolated} with interpolated poses")
            if notes:
                print(f"{r.est_source}: " + "; ".join(notes))
    if args.json:
        doc = {
            "metric": "relations",
            "relations": rel.source,
            "results": [r.to_dict(errors=args.per_relation) for r in results],
            "failed": failed,
        }
        try:
            Path(args.json).write_text(json.dumps(doc, indent=2) + "\n")
        except OSError as exc:
            error_line(args.json, exc)
            return EXIT_BAD_INPUT
    return EXIT_BAD_INPUT if failed else EXIT_OK
