"""``slamq validate RESULTS``: how well each no-reference metric agrees with ground truth."""

from __future__ import annotations

import argparse

from slamq.cli.common import EXIT_BAD_INPUT, EXIT_OK, error_line, stdout_console


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    """Register ``slamq validate``."""
    p = subparsers.add_parser(
        "validate",
        help="rank correlation of each map metric with the ground truth of a results file",
        description="For the sequences of a results file with ground truth (ate_rmse from "
        "trajectories, gt_chamfer / gt_f1 from a ground-truth map), print how well each "
        "no-reference metric orders the maps as the ground truth does: Spearman correlation "
        "(+1 = the same order), pairwise concordance (0.5 = chance) and a permutation "
        "p-value, per sequence and pooled (slamq.results.validity).",
    )
    p.add_argument("results", help="results file (.parquet, .jsonl, .json or .csv)")
    p.add_argument("--permutations", type=int, default=2000, metavar="N",
                   help="shuffles for the p-value (default %(default)s; 0: none)")
    p.add_argument("--all", action="store_true",
                   help="also print every sequence (default: the pooled rows)")
    p.add_argument("--csv", metavar="FILE", help="also write every row as CSV")
    p.add_argument("--json", metavar="FILE", help="also write every row as JSON")
    p.set_defaults(func=handle)


def handle(args: argparse.Namespace) -> int:
    """Print the validity table."""
    from rich.table import Table

    from slamq.errors import ParamError
    from slamq.results.validity import validate

    if args.permutations < 0:
        raise ParamError(f"--permutations must be >= 0, got {args.permutations}")
    table = validate(args.results, permutations=args.permutations)
    if table.empty:
        error_line(args.results, "no sequence with ground truth (ate_rmse, gt_chamfer or "
                   "gt_f1) and at least 3 scored maps")
        return EXIT_BAD_INPUT
    shown = table if args.all else table[table["sequence"] == "(pooled)"]
    out = Table(title=f"{args.results}: rank correlation with ground truth")
    for col in ("metric", "truth", "sequence", "n", "spearman", "concordance", "p"):
        out.add_column(col, justify="left" if col in ("metric", "truth", "sequence")
                       else "right")
    for r in shown.itertuples():
        out.add_row(r.metric, r.truth, r.sequence, str(r.n), f"{r.spearman:+.2f}",
                    f"{r.concordance:.2f}",
                    "-" if r.p_value != r.p_value else f"{r.p_value:.3f}")
    stdout_console().print(out)
    if args.csv:
        table.to_csv(args.csv, index=False)
    if args.json:
        table.to_json(args.json, orient="records", indent=1)
    return EXIT_OK
