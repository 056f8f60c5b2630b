"""GMapping (OpenSLAM's ``openslam_gmapping``) as a ``slamq run`` program, for a study.

GMapping is the RBPF whose relations errors Kümmerle et al. 2009 publish for the real logs
of ``examples/real2d.yaml``. It is not a Debian or PyPI package, so it is not part of
slamq's CI; ``studies/real2d-gmapping.yaml`` runs it through this file when it is built
(docs/validity.md, "GMapping built from its source on the real logs").

Building it (its licence is CC BY-NC-SA 2.0; nothing of it is in this repository): clone
https://github.com/OpenSLAM-org/openslam_gmapping and compile, without its Qt viewer, the
sources of ``utils sensor/* log configfile scanmatcher gridfastslam`` that have no
``main`` (``log/scanstudio2carmen.cpp`` has one the grep misses) and are not
``scanmatcher/scanmatcher.new.cpp``, with ``gui/gsp_thread.cpp`` and ``gui/gfs_nogui.cpp``
into ``gfs_nogui``, and with ``gridfastslam/gfs2log.cpp`` into ``gfs2log`` (``g++ -O2
-DLINUX -I. -Isensor -fpermissive -w ... -lpthread``). g++ 12 refuses one line of
``gui/gsp_thread.cpp`` (``<< cout <<`` inside a stream expression, about line 329): drop
that ``<< cout``. Put both on ``PATH`` or in ``$GMAPPING_BIN``.

What a run does, in the run's ``{out}`` folder:

1. ``gfs_nogui`` on the sequence's CARMEN log (named by the ``conversion.json`` that
   ``slamq run`` writes beside the sequence's rawlog) writes the particles' history;
2. ``gfs2log`` turns it into the best particle's path, a CARMEN log whose
   ``ROBOTLASER1`` lines carry each scan GMapping used at that particle's pose;
3. this file writes ``trajectory.tum`` (those poses at the scans' times) and
   ``map.pgm`` / ``map.yaml``: the scans drawn at those poses, each cell's hits over its
   visits as GMapping's own grid counts them (occupied above 0.25, its ``occ_thresh``).

``python studies/gmapping_run.py RAWLOG OUT --seed N --particles P [gfs_nogui options]``
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np

#: GMapping's default cell occupancy threshold (slam_gmapping's ``occ_thresh``).
OCC_THRESHOLD = 0.25


def _program(name: str) -> str:
    folder = os.environ.get("GMAPPING_BIN")
    path = str(Path(folder) / name) if folder else shutil.which(name)
    if not path or not Path(path).is_file():
        raise SystemExit(f"{name}: not found (set GMAPPING_BIN or PATH; see {__file__})")
    return path


def carmen_source(rawlog: Path) -> Path:
    """The CARMEN log a ``slamq run`` sequence's rawlog was converted from."""
    doc = json.loads((rawlog.parent / "conversion.json").read_text())
    return Path(doc["recipe"]["source"])


def read_robotlaser(path: Path) -> tuple[np.ndarray, list[np.ndarray], np.ndarray,
                                         tuple[float, float, float]]:
    """The ``ROBOTLASER1`` lines of a CARMEN log (read by :class:`slamq.sources.carmen.
    CarmenLog`): their stamps (s), each scan's ranges (m), the laser's poses ``(N, 3)`` and
    ``(first beam's angle, angle step, max range)``.
    """
    from slamq.sources.carmen import CarmenLog, Laser

    lasers = [r for r in CarmenLog(path).records()
              if isinstance(r, Laser) and r.kind == "ROBOTLASER1" and r.laser_pose]
    if not lasers:
        raise SystemExit(f"{path}: no ROBOTLASER1 line (GMapping processed no scan)")
    last = lasers[-1]
    return (np.array([r.stamp for r in lasers]), [r.ranges for r in lasers],
            np.array([r.laser_pose for r in lasers]),
            (last.start_angle, last.angular_resolution, last.max_range))


def write_tum(path: Path, stamps: np.ndarray, poses: np.ndarray) -> None:
    """Poses ``(x, y, yaw)`` at ``stamps`` as a TUM file, in time order (the log's own
    order where stamps tie or run backwards: slamq's ``unsorted: sort``)."""
    from slamq.models.trajectory import Trajectory, order_rows

    o = order_rows(stamps, "sort")
    Trajectory.from_xy_yaw(stamps[o], poses[o, 0], poses[o, 1], poses[o, 2]).write_tum(path)


def draw_map(ranges: list[np.ndarray], poses: np.ndarray, geometry: tuple[float, float, float],
             *, resolution: float = 0.05, usable: float = 50.0,
             max_range: float = 80.0) -> tuple[np.ndarray, tuple[float, float]]:
    """The scans at their poses as an occupancy image (0 occupied, 254 free, 205 unknown;
    row 0 at the top) and its lower-left corner ``(x, y)`` in metres.

    As GMapping's grid (``ScanMatcher::registerScan``): a beam without a return (0, or
    beyond ``max_range``, GMapping's ``maxrange``: the logs write 81.83 m for none) is
    skipped; every cell a beam passes counts a visit, its end cell a visit and a hit; one
    longer than ``usable`` is cut there and hits nothing. A cell is occupied when more than
    ``OCC_THRESHOLD`` of its visits are hits, free when visited otherwise.
    """
    start, step, _ = geometry
    ends_x, ends_y, hit, org_x, org_y = [], [], [], [], []
    for r, (x, y, a) in zip(ranges, poses):
        ang = a + start + step * np.arange(len(r))
        valid = (r > 0) & (r < max_range)
        d = np.minimum(r[valid], usable)
        ends_x.append(x + d * np.cos(ang[valid]))
        ends_y.append(y + d * np.sin(ang[valid]))
        hit.append(r[valid] <= usable)
        org_x.append(np.full(len(d), x))
        org_y.append(np.full(len(d), y))
    ex, ey = np.concatenate(ends_x), np.concatenate(ends_y)
    ox, oy, hit_ = np.concatenate(org_x), np.concatenate(org_y), np.concatenate(hit)
    x0 = math.floor(min(ex.min(), ox.min()) / resolution) * resolution - resolution
    y0 = math.floor(min(ey.min(), oy.min()) / resolution) * resolution - resolution
    w = int(math.ceil((max(ex.max(), ox.max()) - x0) / resolution)) + 2
    h = int(math.ceil((max(ey.max(), oy.max()) - y0) / resolution)) + 2

    def cell(px: np.ndarray, py: np.ndarray) -> np.ndarray:
        return (np.floor((py - y0) / resolution).astype(np.int64) * w
                + np.floor((px - x0) / resolution).astype(np.int64))

    end_cell = cell(ex, ey)
    visits = np.zeros(h * w, np.int64)
    sample = resolution / 2
    chunk = 200_000  # beams at a time
    for k in range(0, len(ex), chunk):
        bx, by = ox[k:k + chunk], oy[k:k + chunk]
        dx, dy = ex[k:k + chunk] - bx, ey[k:k + chunk] - by
        length = np.hypot(dx, dy)
        n = np.ceil(length / sample).astype(np.int64) + 1
        beam = np.repeat(np.arange(len(n)), n)
        first = np.cumsum(n) - n
        t = (np.arange(n.sum()) - first[beam]) * sample
        t = np.minimum(t, length[beam])
        u = t / np.maximum(length[beam], 1e-12)
        c = cell(bx[beam] + u * dx[beam], by[beam] + u * dy[beam])
        keep = np.ones(len(c), bool)
        keep[1:] = (c[1:] != c[:-1]) | (beam[1:] != beam[:-1])
        keep &= c != end_cell[k:k + chunk][beam]  # the end cell: counted below
        visits += np.bincount(c[keep], minlength=h * w)
    hits = np.bincount(end_cell[hit_], minlength=h * w)
    visits += np.bincount(end_cell, minlength=h * w)
    img = np.full(h * w, 205, np.uint8)
    seen = visits > 0
    img[seen] = 254
    img[seen & (hits > OCC_THRESHOLD * visits)] = 0
    return img.reshape(h, w)[::-1].copy(), (x0, y0)


def write_map(folder: Path, img: np.ndarray, corner: tuple[float, float],
              resolution: float) -> None:
    """``map.pgm`` and its map_server ``map.yaml``."""
    import cv2

    cv2.imwrite(str(folder / "map.pgm"), img)
    (folder / "map.yaml").write_text(
        f"image: map.pgm\nresolution: {resolution}\n"
        f"origin: [{corner[0]:.6f}, {corner[1]:.6f}, 0.0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    ap.add_argument("rawlog", type=Path, help="the sequence's rawlog ({input})")
    ap.add_argument("out", type=Path, help="the run's folder ({out})")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--particles", type=int, default=30)
    ap.add_argument("--resolution", type=float, default=0.05, help="m per cell")
    ap.add_argument("--usable", type=float, default=50.0, help="maxUrange, m")
    ap.add_argument("--max-range", type=float, default=80.0, help="maxrange, m")
    a, extra = ap.parse_known_args(argv if argv is not None else sys.argv[1:])
    a.out.mkdir(parents=True, exist_ok=True)
    gfs = a.out / "gmapping.gfs"
    cmd = [_program("gfs_nogui"), "-filename", str(carmen_source(a.rawlog)),
           "-outfilename", str(gfs), "-randseed", str(a.seed), "-particles", str(a.particles),
           "-delta", str(a.resolution), "-maxUrange", str(a.usable),
           "-maxrange", str(a.max_range), *extra]
    with (a.out / "gmapping.log").open("w") as log:
        subprocess.run(cmd, check=True, stdout=log, stderr=subprocess.STDOUT, cwd=a.out)
    best = a.out / "best-path.clf"
    subprocess.run([_program("gfs2log"), str(gfs), str(best)], check=True,
                   stdout=subprocess.DEVNULL, cwd=a.out)
    stamps, ranges, poses, geometry = read_robotlaser(best)
    write_tum(a.out / "trajectory.tum", stamps, poses)
    img, corner = draw_map(ranges, poses, geometry, resolution=a.resolution, usable=a.usable,
                           max_range=a.max_range)
    write_map(a.out, img, corner, a.resolution)
    gfs.unlink()  # hundreds of MB: every particle at every step
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
