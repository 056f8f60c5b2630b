"""A trajectory against its own scans, split in time (docs/validity.md, "A trajectory
against its own scans, split in time"; docs/spec.md 7e).

The scans a trajectory places are cut into two halves in time; each half is drawn as a map
at its poses and the other half's scans are scored against it by docs/spec.md 7b. A wall
that wrong poses draw in one half is crossed by the other half's beams, while a map rebuilt
from all the scans outvotes it. The program's own map is not read, so its drawing
convention does not enter. slamq computes it (:func:`slamq.scan_split`, the beam-walk
drawing of spec 7e); :func:`split_crossing` here is the first prototype, which drew each
scan's swept polygon with OpenCV, kept to reproduce the first tables.

``python studies/split_scans.py OUTPUT [OTHER...]``: every ok record of the ``slamq run``
outputs with scans and a trajectory -> ``LAST/split-rows.csv`` (``map``, ``algorithm``,
``sequence``, ``run``, ``split_crossing``, the two halves' crossing and hit shares,
seconds; resumable: rows already there are kept; ``--polygon``: the prototype, into
``split-polygon-rows.csv``). ``studies/scans_study.py ... --figure split_crossing``
(candidate C1) or ``--figure c2`` (C2) weighs it in the verdict.
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

#: The drawn maps' cell size, metres.
RESOLUTION = 0.05
#: A cell is occupied when hit and its hits are at least this share of its visits.
OCCUPIED = 0.5
#: Scans drawn per half at most, and scored against the other half at most (evenly spread).
MAX_DRAW = 3000
MAX_TEST = 500


def draw(gx: np.ndarray, gy: np.ndarray, lx: np.ndarray, ly: np.ndarray, valid: np.ndarray,
         shape: tuple[int, int], occupied: float = OCCUPIED) -> tuple[np.ndarray, np.ndarray]:
    """Scans drawn as a map: ``(values, unknown)`` (0 occupied, 254 free, 205 unknown).

    ``gx, gy`` (K, B): the beams' ends in grid units (x along columns, y down rows);
    ``lx, ly`` (K,): the laser's; ``valid`` (K, B). Each scan's swept polygon (the laser,
    then each valid beam's end, 1/8-cell fixed point) is one visit of every cell it covers;
    its ends one hit of every cell they end in. Occupied: hit, and hits >= ``occupied`` x
    visits; free: visited and not occupied.
    """
    import cv2

    h, w = shape
    hits = np.zeros((h, w), np.int32)
    visits = np.zeros((h, w), np.int32)
    for k in range(len(lx)):
        v = valid[k]
        if not v.any():
            continue
        ex = np.where(v, gx[k], lx[k])
        ey = np.where(v, gy[k], ly[k])
        poly = np.concatenate([[[lx[k], ly[k]]], np.column_stack([ex, ey])])
        x0 = max(int(np.floor(poly[:, 0].min())) - 1, 0)
        x1 = min(int(np.ceil(poly[:, 0].max())) + 2, w)
        y0 = max(int(np.floor(poly[:, 1].min())) - 1, 0)
        y1 = min(int(np.ceil(poly[:, 1].max())) + 2, h)
        if x1 <= x0 or y1 <= y0:
            continue
        mask = np.zeros((y1 - y0, x1 - x0), np.uint8)
        pts = np.round((poly - [x0 + 0.5, y0 + 0.5]) * 8).astype(np.int32)
        cv2.fillPoly(mask, [pts], 1, lineType=cv2.LINE_8, shift=3)
        visits[y0:y1, x0:x1] += mask
        c = np.floor(gx[k][v]).astype(np.int64)
        r = np.floor(gy[k][v]).astype(np.int64)
        ok = (c >= 0) & (c < w) & (r >= 0) & (r < h)
        hits.ravel()[np.unique(r[ok] * w + c[ok])] += 1
    occ = (hits > 0) & (hits >= occupied * np.maximum(visits, 1))
    free = (visits > 0) & ~occ
    values = np.full((h, w), 205, np.uint8)
    values[free] = 254
    values[occ] = 0
    return values, ~(occ | free)


def split_crossing(scans: Any, traj: Any, *, max_draw: int = MAX_DRAW,
                   max_test: int = MAX_TEST, occupied: float = OCCUPIED) -> dict[str, float]:
    """The split crossing share of a trajectory against its scans, drawn by :func:`draw`.

    Returns ``{"split_crossing", "crossing_1", "crossing_2", "hit_1", "hit_2"}``: the
    second half's scans against the first half's map (``_1``), the first half's against
    the second's (``_2``), and their mean crossing share.

    Examples
    --------
    >>> from slamq.synth import LaserSpec, simulate, world
    >>> from slamq.models import Trajectory
    >>> seq = simulate(world(3, kind="office", size=(10.0, 8.0)), seed=1, noise="none",
    ...                laser=LaserSpec(beams=181), length=20.0)
    >>> from slamq.models.scans import Scans
    >>> s = Scans(seq.stamps, seq.laser.angles(), seq.ranges, seq.laser.max_range,
    ...           offset=seq.laser.offset)
    >>> gt = Trajectory.from_xy_yaw(seq.stamps, *seq.gt.T)
    >>> split_crossing(s, gt)["split_crossing"] < 0.01
    True
    >>> from slamq import scan_split
    >>> scan_split(s, gt).crossing_share < 0.01
    True
    """
    from slamq.metrics.scans import place, scan_consistency
    from slamq.metrics.sync import evenly_spread
    from slamq.models import OccupancyMap
    from slamq.models.scans import Scans

    _, laser, r = place(scans, traj)  # the placed scans' laser poses and ranges
    if len(laser) < 4:
        raise ValueError(f"{scans.source}: the trajectory places {len(laser)} scans")
    valid = np.isfinite(r) & (r > scans.min_range) & (r < scans.max_range)
    a = laser[:, 2:3] + scans.angles[None, :]
    ex = laser[:, 0:1] + np.where(valid, r, 0.0) * np.cos(a)
    ey = laser[:, 1:2] + np.where(valid, r, 0.0) * np.sin(a)
    x0 = min(ex.min(), laser[:, 0].min()) - 1.0
    y0 = min(ey.min(), laser[:, 1].min()) - 1.0
    w = int(math.ceil((max(ex.max(), laser[:, 0].max()) + 1.0 - x0) / RESOLUTION))
    h = int(math.ceil((max(ey.max(), laser[:, 1].max()) + 1.0 - y0) / RESOLUTION))
    gx, gy = (ex - x0) / RESOLUTION, h - (ey - y0) / RESOLUTION
    lx, ly = (laser[:, 0] - x0) / RESOLUTION, h - (laser[:, 1] - y0) / RESOLUTION
    halves = np.array_split(np.arange(len(laser)), 2)
    out: dict[str, float] = {}
    for i, (drawn, tested) in enumerate(((halves[0], halves[1]), (halves[1], halves[0]))):
        d = drawn[evenly_spread(drawn.size, max_draw)]
        values, unknown = draw(gx[d], gy[d], lx[d], ly[d], valid[d], (h, w), occupied)
        grid = OccupancyMap(values, unknown, RESOLUTION, (x0, y0, 0.0))
        t = tested[evenly_spread(tested.size, max_test)]
        part = Scans(np.arange(t.size, dtype=np.float64), scans.angles, r[t],
                     scans.max_range, min_range=scans.min_range)
        c = scan_consistency(grid, part, laser[t])
        out[f"crossing_{i + 1}"] = float(c.crossing_share)
        out[f"hit_{i + 1}"] = float(c.hit_share)
    out["split_crossing"] = (out["crossing_1"] + out["crossing_2"]) / 2.0
    return out


FIELDS = ("map", "algorithm", "sequence", "run", "split_crossing", "crossing_1",
          "crossing_2", "hit_1", "hit_2", "seconds")
#: ``--local``'s rows (docs/spec.md 7f, :func:`slamq.verdict.scans.record_local`).
LOCAL_FIELDS = ("map", "algorithm", "sequence", "run", "local_crossing", "windows", "seconds")


def main(argv: list[str] | None = None) -> int:
    from slamq.results.formats import read_results
    from slamq.sources.trajectories import load_trajectory
    from slamq.verdict.scans import recording

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("output", type=Path, nargs="+", help="slamq run outputs")
    ap.add_argument("--max-draw", type=int, default=MAX_DRAW)
    ap.add_argument("--max-test", type=int, default=MAX_TEST)
    ap.add_argument("--resolution", type=float, default=RESOLUTION,
                    help="the drawn maps' cell size, metres")
    ap.add_argument("--rows", default=None,
                    help="the rows file's name in the last OUTPUT (default split-rows.csv, "
                    "split-polygon-rows.csv with --polygon): a variant of the figure")
    ap.add_argument("--local", action="store_true",
                    help="the local share of docs/spec.md 7f instead, into local-rows.csv "
                    "(docs/validity.md, 'A fifth real log ... a floor from the recording')")
    ap.add_argument("--polygon", action="store_true",
                    help="the prototype (swept polygons), into split-polygon-rows.csv")
    a = ap.parse_args(argv if argv is not None else sys.argv[1:])
    store = a.output[-1] / (a.rows or ("split-polygon-rows.csv" if a.polygon
                                       else "local-rows.csv" if a.local
                                       else "split-rows.csv"))
    done = set()
    if store.exists():
        with store.open() as f:
            done = {r["map"] for r in csv.DictReader(f)}
    new = not store.exists()
    with store.open("a", newline="") as f:
        out = csv.DictWriter(f, LOCAL_FIELDS if a.local else FIELDS)
        if new:
            out.writeheader()
        for folder in a.output:
            recs = read_results(folder / "results.jsonl")
            for r in recs.to_dict("records"):
                if (not isinstance(r.get("map"), str) or r["map"] in done
                        or not isinstance(r.get("scans"), str)
                        or not isinstance(r.get("trajectory"), str)
                        or (isinstance(r.get("error"), str) and r["error"])):
                    continue
                t0 = time.time()
                try:
                    scans = recording(r["scans"])
                    traj = load_trajectory(r["trajectory"], unsorted="sort")
                    if a.local:
                        from slamq.verdict.scans import record_local

                        fig = record_local(r)
                    elif a.polygon:
                        fig = split_crossing(scans, traj, max_draw=a.max_draw,
                                             max_test=a.max_test)
                    else:
                        from slamq import scan_split

                        fig = scan_split(scans, traj, max_draw=a.max_draw,
                                         max_test=a.max_test,
                                         resolution=a.resolution).to_dict()
                        del fig["drawn"], fig["tested"]
                except Exception as exc:  # noqa: BLE001 - a study row says why it failed
                    print(f"{r['map']}: {type(exc).__name__}: {exc}", file=sys.stderr)
                    continue
                row = {"map": r["map"], "algorithm": r["algorithm"],
                       "sequence": r["sequence"], "run": r["run"], **fig,
                       "seconds": round(time.time() - t0, 2)}
                out.writerow(row)
                f.flush()
                print(r["algorithm"], r["sequence"], r["run"],
                      f"{100 * fig.get('split_crossing', fig.get('local_crossing')):.2f}%",
                      row["seconds"], flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
