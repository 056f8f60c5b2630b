"""Does a map's support (``slamq.agreement``) depend on its grid's resolution? A study of
docs/validity.md, "Support leans to the coarser grid".

For every sequence of a generated set with the three MRPT programs (rbpf-slam draws its
maps at 0.07 m, icp-slam and graphslam-engine at 0.05 m), the agreement of the three maps
is computed four ways, each map keeping its own path and content:

- ``default``: as the verdict computes it (``align="auto"``, each pair's tolerance two
  cells of the grid it is laid on);
- ``one tolerance``: every pair at one tolerance in metres, two cells of the coarsest grid;
- ``icp at 0.07``: icp-slam's map resampled to rbpf-slam's grid first (:func:`on_grid`),
  the other maps as they are;
- ``all at the coarsest``: every map on the coarsest grid first (candidate C1 of
  docs/validity.md, "Support on the coarsest grid", measured and not adopted).

If support were neutral to the grid, resampling icp-slam's map would not move its support;
the rows print each program's support and the count of sequences where rbpf-slam's is
above icp-slam's, beside the program that is best by ATE (``summary.csv``).

Usage (from the repository's root; a set made by ``slamq run studies/scans-benchmark-X.yaml``)::

    python studies/support_grid_study.py studies/scans-benchmark-ah-runs [...]
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import cv2
import numpy as np
import pandas as pd

from slamq import agreement, load_map
from slamq.models import OccupancyMap

PROGRAMS = ("icp-slam", "rbpf-slam", "graphslam-engine")


def _area_shares(a: np.ndarray, ratio: float) -> np.ndarray:
    """``a`` (float32, one value per fine cell, rows counted from the map's bottom edge)
    averaged over coarse cells ``1 / ratio`` fine cells wide from the same corner: each
    coarse cell the exact area-weighted mean of the fine cells it overlaps (OpenCV's
    ``INTER_AREA`` at the scale ``ratio``; zeros past the map). The grid covers the map."""
    h, w = a.shape
    nh, nw = (max(1, int(math.ceil(n * ratio - 1e-9))) for n in (h, w))
    # padded so that the scaled size covers the map and differs from the padded one (OpenCV
    # copies an image whose size the scale leaves unchanged)
    least = int(math.ceil(0.5 / (1.0 - ratio))) + 1
    ph = max(int(math.ceil(nh / ratio)) + 2, least) - h
    pw = max(int(math.ceil(nw / ratio)) + 2, least) - w
    padded = cv2.copyMakeBorder(a, 0, max(ph, 0), 0, max(pw, 0), cv2.BORDER_CONSTANT,
                                value=0)
    out = cv2.resize(padded, (0, 0), fx=ratio, fy=ratio, interpolation=cv2.INTER_AREA)
    return out[:nh, :nw]


def on_grid(m: OccupancyMap, res: float) -> OccupancyMap:
    """``m`` on a coarser grid of ``res`` metres from the same lower-left corner.

    A coarse cell is occupied where at least ``min(0.2, fine / coarse / 2)`` of its area is
    occupied (a wall one fine cell thick, split between two coarse cells, leaves a wall in
    one of them), known where more than half of its area is known or where it is occupied.
    The areas are exact (rows from the map's bottom edge, columns from its left edge; a
    share within 1e-6 of its bar counts as occupied, and as not known); the grid covers the
    whole map. ``res`` equal to the map's returns the map.

    Examples
    --------
    >>> img = np.full((10, 14), 254, np.uint8); img[:, 6] = 0      # a wall one cell thick
    >>> c = on_grid(OccupancyMap(img, np.zeros(img.shape, bool), 0.05), 0.07)
    >>> c.shape, c.resolution, np.flatnonzero(c.values[-1] == 0).tolist()
    ((8, 10), 0.07, [4])
    """
    fine = float(m.resolution)
    if not res >= fine > 0:
        raise ValueError(f"on_grid: {res!r} m is finer than the map's {fine!r} m")
    if math.isclose(res, fine, rel_tol=1e-9):
        return m
    ratio = fine / res
    occ = ((m.values < 127.5) & ~m.unknown)[::-1].astype(np.float32)  # rows from the bottom
    known = (~m.unknown)[::-1].astype(np.float32)
    occupied = _area_shares(occ, ratio) >= min(0.2, 0.5 * ratio) - 1e-6
    unknown = ~((_area_shares(known, ratio) > 0.5 + 1e-6) | occupied)
    values = np.where(occupied, 0, np.where(unknown, 205, 254)).astype(np.uint8)
    return OccupancyMap(np.ascontiguousarray(values[::-1]),
                        np.ascontiguousarray(unknown[::-1]), float(res), m.origin,
                        source=f"{m.source}@{res:g}m")


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
        resampled = dict(maps, **{"icp-slam": on_grid(maps["icp-slam"],
                                                      maps["rbpf-slam"].resolution)})
        at07 = agreement(resampled, align="auto", threads=1)
        common = agreement({a: on_grid(m, coarsest) for a, m in maps.items()}, align="auto",
                           threads=1)
        ate = summary[summary["sequence"] == seq].set_index("algorithm")["ate_rmse_mean"]
        row = {"sequence": seq, "ate_best": str(ate.idxmin())}
        for name, a in (("default", default), ("one tolerance", one_tol),
                        ("icp at 0.07", at07), ("all at the coarsest", common)):
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
        for name in ("default", "one tolerance", "icp at 0.07", "all at the coarsest"):
            lean = int((t[f"rbpf {name}"] > t[f"icp {name}"]).sum())
            print(f"- {name}: rbpf-slam's support above icp-slam's in {lean} of {len(t)}")
        gain = (t["icp icp at 0.07"] - t["icp default"]).median()
        print(f"- icp-slam's support moved by resampling its map to 0.07 m: median {gain:+.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
