"""Study: which ``canonical_resolution`` (spec section 3a) to default to.

Not a timing benchmark: for each candidate reference resolution it measures, on the real
maps of ../shared/data (skipped when absent),

- the invariance of ``corners_canonical`` (issue 13, item 2): the median relative change
  under the perturbations of ``tests/test_canonical.py`` (turned 1, 2, 5, 10, 30 degrees; a
  2x finer and a 2x coarser grid) over the same corpus as that test;
- whether it still tells the broken maps from the good ones: on slam_comparison_tools, per
  world, the broken cartographer map's count over the lowest count of the other four
  algorithms (near 1: the broken map hides among the good ones);
- its pooled pairwise concordance with the ATE RMSE there (0.5 = chance).

The table it prints is the one in docs/spec.md, section 3a.

Usage::

    python studies/canonical_sweep.py [--references 0.05 0.06 0.07 0.08 0.1] [--data DIR]
"""

from __future__ import annotations

import argparse
import itertools
import sys
import warnings
from pathlib import Path

import numpy as np
from _common import REPO, SHARED_DATA

import slamq

sys.path.insert(0, str(REPO / "tests"))  # the invariance test's corpus and perturbations
from conftest import comparison_tools_runs  # noqa: E402
from test_canonical import FAST, PERTURBATIONS, _corpus  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--references", type=float, nargs="+",
                    default=[0.05, 0.06, 0.07, 0.08, 0.1])
    ap.add_argument("--data", type=Path, default=SHARED_DATA,
                    help=f"the real-map corpus (default {SHARED_DATA})")
    args = ap.parse_args()
    if not (args.data / "maps").is_dir():
        print(f"skipped: no corpus at {args.data}")
        return 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        corpus = _corpus(args.data)
    runs = [(w, a, slamq.load_map(y), ate) for w, a, y, ate in comparison_tools_runs(args.data)]
    print(f"{len(corpus)} corpus maps; slam_comparison_tools: {len(runs)} runs\n")
    print("| reference | median change: " + " / ".join(PERTURBATIONS)
          + " | largest | broken / best good map | concordance with ATE |")
    print("|---|---|---|---|---|")
    for ref in args.references:
        def count(m: slamq.OccupancyMap, ref: float = ref) -> int:
            return slamq.evaluate(m, canonical_resolution=ref, **FAST).corners_canonical or 0

        base = [count(m) for m in corpus]
        med = {}
        for name, perturb in PERTURBATIONS.items():
            change = [count(perturb(m)) / max(b, 1) - 1 for m, b in zip(corpus, base)]
            med[name] = float(np.median(change))
        worst = max(med, key=lambda k: abs(med[k]))
        per: dict[str, list[tuple[str, int, float]]] = {}
        for world, alg, m, ate in runs:
            per.setdefault(world, []).append((alg, count(m), ate))
        same = pairs = 0
        ratios = []
        for rows in per.values():
            for (_, c1, e1), (_, c2, e2) in itertools.combinations(rows, 2):
                if c1 != c2 and e1 != e2:
                    pairs += 1
                    same += (c1 < c2) == (e1 < e2)
            broken = [c for a, c, _ in rows if a == "cartographer"]
            good = [c for a, c, _ in rows if a != "cartographer"]
            if broken and good:
                ratios.append(broken[0] / max(min(good), 1))
        print(f"| {ref:g} m | " + " / ".join(f"{100 * v:+.1f}%" for v in med.values())
              + f" | {100 * abs(med[worst]):.1f}% ({worst}) | "
              + " / ".join(f"{r:.2f}" for r in ratios)
              + f" | {same / pairs:.2f} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
