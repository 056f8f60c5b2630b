"""Does a map's support (``slamq.agreement``) depend on its grid's resolution? A study of
docs/validity.md, "Support leans to the coarser grid".

For every sequence of a generated set with the three MRPT programs (rbpf-slam draws its
maps at 0.07 m, icp-slam and graphslam-engine at 0.05 m), the agreement of the three maps
is computed three ways, each map keeping its own path and content:

- ``default``: as the verdict computes it (``align="auto"``, each pair's tolerance two
  cells of the grid it is laid on);
- ``one tolerance``: every pair at one tolerance in metres, two cells of the coarsest grid;
- ``icp at 0.07``: icp-slam's map resampled to rbpf-slam's grid first (a cell occupied
  where at least a fifth of its area is, known where more than half of it is), the other
  maps as they are.

If support were neutral to the grid, resampling icp-slam's map would not move its support;
the rows print each program's support and the count of sequences where rbpf-slam's is
above icp-slam's, beside the program that is best by ATE (``summary.csv``).

Usage (from the repository's root; a set made by ``slamq run studies/scans-benchmark-X.yaml``)::

    python studies/support_grid_study.py studies/scans-benchmark-ah-runs [...]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import numpy as np
import pandas as pd

from slamq import agreement, load_map
from slamq.models import OccupancyMap

PROGRAMS = ("icp-slam", "rbpf-slam", "graphslam-engine")


def coarse(m: OccupancyMap, res: float) -> OccupancyMap:
    """``m`` on a grid of ``res`` metres from the same lower-left corner: a cell is occupied
    where at least a fifth of its area is occupied, known where more than half is known."""
    h, w = m.shape
    nh, nw = int(round(h * m.resolution / res)), int(round(w * m.resolution / res))
    occ = ((m.values < 128) & ~m.unknown).astype(np.float32)
    known = (~m.unknown).astype(np.float32)
    o = cv2.resize(occ, (nw, nh), interpolation=cv2.INTER_AREA) > 0.2
    k = cv2.resize(known, (nw, nh), interpolation=cv2.INTER_AREA) > 0.5
    values = np.where(o, 0, 254).astype(np.uint8)
    return OccupancyMap(values, ~(k | o), res, m.origin, source=f"{m.source}@{res:g}m")


def study(root: Path) -> pd.DataFrame:
    summary = pd.read_csv(root / "summary.csv")
    rows = []
    for seq in sorted(summary["sequence"].unique()):
        paths = {a: root / a / "default" / seq / "1" / "map.yaml" for a in PROGRAMS}
        if not all(p.is_file() for p in paths.values()):
            continue
        maps = {a: load_map(p) for a, p in paths.items()}
        coarsest = max(m.resolution for m in maps.values())
        default = agreement(maps, align="auto", threads=1)
        one_tol = agreement(maps, align="auto", threads=1, tolerance=2.0 * coarsest)
        resampled = dict(maps, **{"icp-slam": coarse(maps["icp-slam"],
                                                     maps["rbpf-slam"].resolution)})
        at07 = agreement(resampled, align="auto", threads=1)
        ate = summary[summary["sequence"] == seq].set_index("algorithm")["ate_rmse_mean"]
        row = {"sequence": seq, "ate_best": str(ate.idxmin())}
        for name, a in (("default", default), ("one tolerance", one_tol),
                        ("icp at 0.07", at07)):
            row[f"icp {name}"] = a.support["icp-slam"]
            row[f"rbpf {name}"] = a.support["rbpf-slam"]
        rows.append(row)
    return pd.DataFrame(rows)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", nargs="+", type=Path, help="run folders of generated sets")
    args = ap.parse_args(argv)
    for root in args.runs:
        t = study(root)
        print(f"\n{root}: {len(t)} sequences; best by ATE: "
              + ", ".join(f"{k} {v}" for k, v in t["ate_best"].value_counts().items()))
        print(t.round(3).to_string(index=False))
        for name in ("default", "one tolerance", "icp at 0.07"):
            lean = int((t[f"rbpf {name}"] > t[f"icp {name}"]).sum())
            print(f"- {name}: rbpf-slam's support above icp-slam's in {lean} of {len(t)}")
        gain = (t["icp icp at 0.07"] - t["icp default"]).median()
        print(f"- icp-slam's support moved by resampling its map to 0.07 m: median {gain:+.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
