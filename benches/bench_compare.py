"""Benchmark: ``slamq.compare`` (ICP included) on a 1-Mcell estimate against a 1-Mcell
ground truth, against the same computation written with ``scipy.ndimage`` + OpenCV, same
maps, same run.

Synthesises a 50 m x 50 m building at 0.05 m/cell (1000 x 1000 cells): a ground truth with
one-cell walls, every cell known; an estimate with two-cell walls, unknown outside the
building, a few stray occupied cells, saved in a frame that is off by (0.3 m, -0.2 m, 2
degrees). Then times, maps already in memory:

- slamq: ``slamq.compare(est, gt, align="icp")`` (and ``align="origin"``), one thread;
- the scipy/OpenCV pipeline, one thread: ``scipy.ndimage.distance_transform_edt`` with
  indices for the ground truth (ICP correspondences and d(e, G)), OpenCV box filters for the
  local wall lines, the same trimmed point-to-line ICP in numpy, ``cv2.warpAffine``
  (nearest) to resample the estimate, ``distance_transform_edt`` of the aligned estimate,
  the figures in numpy;

checks that both find the same alignment and figures, and prints a table with the ratios
measured in this run.

Usage::

    PYTHONPATH=python python benches/bench_compare.py [--size 1000] [--repeat 7]
"""

from __future__ import annotations

import os

# one thread everywhere: idle BLAS/OpenMP worker threads would also compete for the CPU
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import math  # noqa: E402
import platform  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import cv2  # noqa: E402
import numpy as np  # noqa: E402

RES = 0.05
#: The error of the estimate's frame: (dx, dy, dyaw degrees).
FRAME_ERROR = (0.3, -0.2, 2.0)


def _segments(extent: float, rng: np.random.Generator) -> list[tuple[float, ...]]:
    """Wall segments (x0, y0, x1, y1) in metres: an outline, rooms with doors, boxes."""
    lo, hi = 2.0, extent - 2.0
    segs = [(lo, lo, hi, lo), (hi, lo, hi, hi), (hi, hi, lo, hi), (lo, hi, lo, lo)]
    step = 8.0
    k = lo + step
    while k < hi - 1:
        for a in np.arange(lo, hi - 1e-9, step):
            b = min(a + step, hi)
            door = a + rng.uniform(1.0, step - 2.0)
            segs.append((k, a, k, door))           # vertical wall with a 1 m door
            segs.append((k, door + 1.0, k, b))
            door = a + rng.uniform(1.0, step - 2.0)
            segs.append((a, k, door, k))           # horizontal wall with a door
            segs.append((door + 1.0, k, b, k))
        k += step
    for _ in range(int(extent)):                   # boxes (furniture)
        x, y = rng.uniform(lo + 1, hi - 2, 2)
        w, h = rng.uniform(0.3, 1.2, 2)
        segs += [(x, y, x + w, y), (x + w, y, x + w, y + h), (x + w, y + h, x, y + h),
                 (x, y + h, x, y)]
    return segs


def _draw(segs, size: int, motion: tuple[float, float, float], thickness: int) -> np.ndarray:
    """Occupancy image (0 walls, 254 free) of the segments moved by ``motion``."""
    img = np.full((size, size), 254, np.uint8)
    dx, dy, dyaw = motion
    c, s = math.cos(math.radians(dyaw)), math.sin(math.radians(dyaw))
    shift = 4  # sub-pixel drawing precision
    for x0, y0, x1, y1 in segs:
        pts = []
        for x, y in ((x0, y0), (x1, y1)):
            wx, wy = c * x - s * y + dx, s * x + c * y + dy
            col, row = wx / RES - 0.5, size - wy / RES - 0.5
            pts.append((int(round(col * (1 << shift))), int(round(row * (1 << shift)))))
        cv2.line(img, pts[0], pts[1], 0, thickness, lineType=cv2.LINE_8, shift=shift)
    return img


def synthesize(size: int = 1000, seed: int = 0):
    """``(estimate, ground_truth)`` OccupancyMaps of one synthetic building."""
    import slamq

    rng = np.random.default_rng(seed)
    extent = size * RES
    segs = _segments(extent, rng)
    gt = _draw(segs, size, (0.0, 0.0, 0.0), 1)
    # the estimate's frame is off by FRAME_ERROR: its file says "origin (0, 0, 0)" but the
    # walls are drawn where that error puts them
    est = _draw(segs, size, FRAME_ERROR, 2)
    corners = []
    dx, dy, dyaw = FRAME_ERROR
    c, s = math.cos(math.radians(dyaw)), math.sin(math.radians(dyaw))
    for x, y in ((2, 2), (extent - 2, 2), (extent - 2, extent - 2), (2, extent - 2)):
        wx, wy = c * x - s * y + dx, s * x + c * y + dy
        corners.append((round(wx / RES - 0.5), round(size - wy / RES - 0.5)))
    mask = np.zeros((size, size), np.uint8)
    cv2.fillPoly(mask, [np.array(corners, np.int32)], 1)
    mask = cv2.dilate(mask, np.ones((5, 5), np.uint8))
    unknown = mask == 0
    stray = rng.random((size, size)) < 0.0005
    est[stray & ~unknown] = 0
    est[unknown] = 205
    return (slamq.OccupancyMap(est, unknown, RES, (0.0, 0.0, 0.0), "<estimate>"),
            slamq.OccupancyMap(gt, np.zeros_like(unknown), RES, (0.0, 0.0, 0.0),
                               "<ground truth>"))


# --------------------------------------------------------------------------- scipy + cv2


def _cell_centres(rows, cols, height, res, origin):
    x = (cols + 0.5) * res
    y = (height - rows - 0.5) * res
    c, s = math.cos(origin[2]), math.sin(origin[2])
    return c * x - s * y + origin[0], s * x + c * y + origin[1]


def scipy_compare(est, gt, tolerance_cells=2.0, trim=0.2, max_iterations=100):
    """The same computation as slamq.compare(align="icp") with scipy.ndimage and OpenCV."""
    from scipy import ndimage

    h, w = gt.shape
    res = gt.resolution
    e_occ = ~est.unknown & (est.values < 128)
    g = ~gt.unknown & (gt.values < 128)
    # ground-truth distance transform with the nearest occupied cell of every cell
    _, (near_r, near_c) = ndimage.distance_transform_edt(~g, return_indices=True)
    all_r, all_c = np.mgrid[0:h, 0:w]
    # local line of every ground-truth cell: moments of the 5x5 window, by box filters
    gf = g.astype(np.float64)
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
    box = lambda a: cv2.boxFilter(a, -1, (5, 5), normalize=False,  # noqa: E731
                                  borderType=cv2.BORDER_CONSTANT)
    n = box(gf)
    sx, sy = box(gf * xx), box(gf * yy)
    sxx, sxy, syy = box(gf * xx * xx), box(gf * xx * yy), box(gf * yy * yy)
    with np.errstate(invalid="ignore", divide="ignore"):
        mx, my = sx / n, sy / n
        a, b, d = sxx / n - mx * mx, sxy / n - mx * my, syy / n - my * my
    half = 0.5 * (a + d)
    root = np.sqrt(0.25 * (a - d) ** 2 + b * b)
    big, small = half + root, half - root
    line = g & (n >= 3) & (big > 0) & (small <= 0.1 * big)
    ex = np.where(np.abs(b) > 1e-12, small - d, np.where(a <= d, 1.0, 0.0))
    ey = np.where(np.abs(b) > 1e-12, b, np.where(a <= d, 0.0, 1.0))
    # world: +col = +x, +row = -y (yaw 0 maps)
    norm = np.hypot(ex, ey)
    nx, ny = np.where(line, ex / norm, 0.0), np.where(line, -ey / norm, 0.0)
    lx, ly = _cell_centres(np.where(line, my, yy), np.where(line, mx, xx), h, res, gt.origin)
    # estimate points
    er, ec = np.nonzero(e_occ)
    px, py = _cell_centres(er.astype(float), ec.astype(float), est.shape[0],
                           est.resolution, est.origin)
    def run(sx, sy, theta, tx, ty, iterations, eps_cells):
        """slamq's ICP loop (rust/src/icp.rs) on points (sx, sy)."""
        keep = min(len(sx), max(1, math.ceil((1 - trim) * len(sx))))
        cx, cy = sx.mean(), sy.mean()
        radius = np.hypot(sx - cx, sy - cy).max()
        done = 0
        while done < iterations:
            c, s = math.cos(theta), math.sin(theta)
            qx, qy = c * sx - s * sy + tx, s * sx + c * sy + ty
            col = np.clip(np.floor((qx - gt.origin[0]) / res), 0, w - 1).astype(np.intp)
            row = np.clip(np.floor(h - (qy - gt.origin[1]) / res), 0, h - 1).astype(np.intp)
            tr, tc = near_r[row, col], near_c[row, col]
            gx, gy = _cell_centres(tr.astype(float), tc.astype(float), h, res, gt.origin)
            d2 = (qx - gx) ** 2 + (qy - gy) ** 2
            if keep < len(d2):
                idx = np.sort(np.argpartition(d2, keep - 1)[:keep])
            else:
                idx = np.arange(len(d2))
            qx, qy, tr, tc = qx[idx], qy[idx], tr[idx], tc[idx]
            ox, oy = qx.mean(), qy.mean()
            rx, ry = qx - ox, qy - oy
            nxi, nyi = nx[tr, tc], ny[tr, tc]
            is_line = (nxi != 0) | (nyi != 0)
            rows = [np.stack([nxi * -ry + nyi * rx, nxi, nyi], 1)[is_line]]
            rhs = [(nxi * (qx - lx[tr, tc]) + nyi * (qy - ly[tr, tc]))[is_line]]
            pt = ~is_line
            cx, cy = _cell_centres(tr[pt].astype(float), tc[pt].astype(float), h, res,
                                   gt.origin)
            rows += [np.stack([-ry[pt], np.ones(pt.sum()), np.zeros(pt.sum())], 1),
                     np.stack([rx[pt], np.zeros(pt.sum()), np.ones(pt.sum())], 1)]
            rhs += [qx[pt] - cx, qy[pt] - cy]
            jac, r = np.concatenate(rows), np.concatenate(rhs)
            step = np.linalg.solve(jac.T @ jac, -jac.T @ r)
            cs, sn = math.cos(step[0]), math.sin(step[0])
            dtx = ox + step[1] - (cs * ox - sn * oy)
            dty = oy + step[2] - (sn * ox + cs * oy)
            tx, ty = cs * tx - sn * ty + dtx, sn * tx + cs * ty + dty
            theta += step[0]
            done += 1
            if abs(step[0]) * radius + math.hypot(step[1], step[2]) < eps_cells * res:
                break
        return theta, tx, ty, done

    def subsample(n):
        stride = max(1, -(-len(px) // n))
        return px[::stride], py[::stride]

    # coarse to fine, as slamq: 2048 points to half a cell, then 8192 to 0.05 cells
    theta, tx, ty, n1 = run(*subsample(2048), 0.0, 0.0, 0.0, max_iterations, 0.5)
    theta, tx, ty, _ = run(*subsample(8192), theta, tx, ty, max_iterations - n1, 0.05)
    # resample the estimate onto the ground truth's grid (nearest), plus its points pushed
    c, s = math.cos(theta), math.sin(theta)
    # ground-truth cell (col, row) -> world -> inverse motion -> estimate cell (yaw-0 frames)
    he = est.shape[0]
    gx0, gy0 = 0.5 * res + gt.origin[0], (h - 0.5) * res + gt.origin[1]
    def est_cell(col, row):
        x, y = gx0 + col * res, gy0 - row * res
        xr, yr = c * (x - tx) + s * (y - ty), -s * (x - tx) + c * (y - ty)
        return ((xr - est.origin[0]) / est.resolution,
                he - (yr - est.origin[1]) / est.resolution)
    o = est_cell(0, 0)
    dc, dr = est_cell(1, 0), est_cell(0, 1)
    m = np.array([[dc[0] - o[0], dr[0] - o[0], o[0] - 0.5],
                  [dc[1] - o[1], dr[1] - o[1], o[1] - 0.5]])
    flags = (e_occ.astype(np.uint8) | ((~est.unknown).astype(np.uint8) << 1))
    on_gt = cv2.warpAffine(flags, m, (w, h), flags=cv2.INTER_NEAREST | cv2.WARP_INVERSE_MAP,
                           borderMode=cv2.BORDER_CONSTANT, borderValue=0)
    e = (on_gt & 1).astype(bool)
    known = (on_gt & 2).astype(bool)
    qx, qy = c * px - s * py + tx, s * px + c * py + ty
    col = np.floor((qx - gt.origin[0]) / res).astype(np.intp)
    row = np.floor(h - (qy - gt.origin[1]) / res).astype(np.intp)
    inside = (col >= 0) & (col < w) & (row >= 0) & (row < h)
    e[row[inside], col[inside]] = True
    known[row[inside], col[inside]] = True
    d_eg = np.hypot(near_r - all_r, near_c - all_c)  # from the indices found above
    d_ge = ndimage.distance_transform_edt(~e)
    tol = tolerance_cells
    precision = float(np.mean(d_eg[e] <= tol))
    recall = float(np.mean(d_ge[g] <= tol))
    free = ~gt.unknown & ~g
    return {
        "precision": precision, "recall": recall,
        "f1": 2 * precision * recall / (precision + recall),
        "iou": float((e & g).sum() / (e | g).sum()),
        "ne": float(d_ge[g].mean() * res), "reverse": float(d_eg[e].mean() * res),
        "coverage": float((free & known).sum() / free.sum()),
        "dx": tx, "dy": ty, "dyaw": math.degrees(theta),
    }


def _best(fn, repeat: int) -> tuple[float, object]:
    best, out = math.inf, None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best * 1e3, out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", type=int, default=1000, help="cells per side (default 1000)")
    ap.add_argument("--repeat", type=int, default=7, help="runs per timing; the minimum")
    args = ap.parse_args()
    import scipy

    import slamq

    cv2.setNumThreads(1)
    est, gt = synthesize(args.size)
    cells = gt.values.size
    print(f"- machine: {platform.machine()}, {os.cpu_count()} cores, Python "
          f"{platform.python_version()}, numpy {np.__version__}, scipy {scipy.__version__}, "
          f"OpenCV {cv2.__version__}")
    print(f"- maps: estimate {est.shape[0]} x {est.shape[1]}, ground truth {gt.shape[0]} x "
          f"{gt.shape[1]} = {cells / 1e6:.2f} Mcells each; frame error {FRAME_ERROR}")
    print(f"- minimum of {args.repeat} runs; one thread everywhere\n")
    rows = []
    ms_icp, c = _best(lambda: slamq.compare(est, gt, align="icp", threads=1), args.repeat)
    rows.append(("slamq.compare, align=icp", ms_icp))
    ms_origin, _ = _best(lambda: slamq.compare(est, gt, align="origin", threads=1),
                         args.repeat)
    rows.append(("slamq.compare, align=origin", ms_origin))
    ms_scipy, ref = _best(lambda: scipy_compare(est, gt), max(1, args.repeat // 2))
    rows.append(("scipy.ndimage + cv2 (same ICP, figures)", ms_scipy))
    print("| implementation | ms | ms/Mcell | x slamq icp |")
    print("|---|---:|---:|---:|")
    for name, ms in rows:
        print(f"| {name} | {ms:.1f} | {ms / (cells / 1e6):.1f} | {ms / ms_icp:.1f} |")
    print()
    print(f"slamq: dx {c.dx:.4f} m, dy {c.dy:.4f} m, dyaw {c.dyaw:.3f} deg "
          f"({c.icp_iterations} iterations, inlier RMS {c.icp_rms:.4f} m); "
          f"scipy pipeline: dx {ref['dx']:.4f}, dy {ref['dy']:.4f}, dyaw {ref['dyaw']:.3f}")
    names = ("precision", "recall", "f1", "iou", "ne", "reverse", "coverage")
    print("figures, slamq / scipy: " + ", ".join(
        f"{k} {getattr(c, k):.4f}/{ref[k]:.4f}" for k in names))
    worst = max(abs(getattr(c, k) - ref[k]) for k in names)
    ok = (worst < 0.01 and abs(c.dyaw - ref["dyaw"]) < 0.05
          and math.hypot(c.dx - ref["dx"], c.dy - ref["dy"]) < 0.5 * RES)
    print(f"largest figure difference {worst:.2g}: {'agree' if ok else 'DISAGREE'}")
    print(f"\nspeed-up over scipy + cv2: {ms_scipy / ms_icp:.1f}x; slamq icp "
          f"{'within' if ms_icp <= 20 else 'OVER'} the 20 ms budget")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
