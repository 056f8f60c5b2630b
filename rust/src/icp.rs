//! Trimmed SE(2) ICP of a map's occupied cells onto a ground truth whose distance transform
//! gives every cell's nearest occupied cell (SPEC section 7).
//!
//! Each point is paired with the nearest occupied target cell (the distance transform's
//! label of the cell the point falls in). Where the target's occupied cells around that
//! cell form a line (a wall), the pair's residual is the distance to that line
//! (point-to-line, which lets walls slide along each other and reaches sub-cell accuracy);
//! elsewhere (corners, clutter) it is the distance to the cell's centre (point-to-point).
//!
//! Deterministic: correspondences are computed per point in fixed chunks; the trimmed set is
//! chosen by (distance, point index), a total order; sums run in point order.

use crate::edt::{Columns, EdtError, NearestCell, Sparse};
use crate::se2::{Affine, Frame, Se2};
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

/// Points per parallel chunk (fixed, so the work split does not depend on the thread count).
const CHUNK: usize = 4096;
/// Stop when a step moves no point by more than this many target cells.
const EPS_MOVE: f64 = 0.05;
/// The ICP uses at most this many points: an even subsample (every k-th in row-major order)
/// of larger sets; its first, coarse stage at most [`COARSE_POINTS`], until a step moves
/// no point by more than [`EPS_COARSE`] cells.
pub const MAX_POINTS: usize = 8192;
pub const COARSE_POINTS: usize = 2048;
const EPS_COARSE: f64 = 0.5;
/// Half-size of the window (cells) whose occupied cells are fitted with a line.
const LINE_WINDOW: isize = 2;
/// A window is a line when its smaller spread is below this share of the larger one.
const LINE_RATIO: f64 = 0.1;

/// What the ICP found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IcpResult {
    /// The motion of the estimate's world frame onto the ground truth's.
    pub transform: Se2,
    /// Root mean square distance (metres) from the kept (inlier) points, at `transform`, to
    /// the centre of their nearest occupied target cell.
    pub rms: f64,
    /// Iterations run.
    pub iterations: usize,
    /// Pairs kept at the last iteration.
    pub inliers: usize,
}

/// The local shape of the target around one occupied cell.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Local {
    /// Centroid of the occupied cells of the window (world).
    cx: f64,
    cy: f64,
    /// Unit normal of their line; (0, 0) when they do not form a line.
    nx: f64,
    ny: f64,
}

/// Which target cells are occupied: a mask, or the bits of [`Sparse`] (the same cells:
/// the same line fits).
#[derive(Clone, Copy)]
pub enum Occupied<'a> {
    Mask(&'a [bool]),
    Bits(&'a Sparse),
}

/// The target: the ground truth's frame, the distance transform of its occupied cells, and
/// the local line of every occupied cell.
pub struct Target<'a> {
    frame: Frame,
    to_cell: Affine,
    /// The last row and column, as floats (for [`floor_clamp_top`]).
    top: (f64, f64),
    to_world: Affine,
    /// Nearest-occupied-cell queries ([`crate::edt::Columns`] or [`crate::edt::Sparse`]:
    /// the same answers).
    columns: &'a dyn NearestCell,
    /// `columns` when they are [`Columns`], called directly (no dynamic call, no division
    /// of the cell index).
    dense: Option<&'a Columns>,
    /// Which cells are occupied.
    occupied: Occupied<'a>,
    /// Occupied cells (row-major indices, ascending) and their local shapes (fitted on
    /// first use: the ICP looks at a fraction of them).
    cells: &'a [u32],
    /// `cells[row_start[r]..row_start[r + 1]]` are the occupied cells of row `r`.
    row_start: Vec<u32>,
    local: Vec<Slot>,
}

/// A [`Local`] fitted on first use. Threads sharing the target (parallel ICP runs from
/// several starts) may fit the same cell at once: they store the same bits, and `ready` is set
/// (release) after them, so whoever reads it set (acquire) reads the fit.
#[derive(Default)]
struct Slot {
    ready: AtomicBool,
    bits: [AtomicU64; 4],
}

impl Slot {
    #[inline]
    fn get_or_fit(&self, fit: impl FnOnce() -> Local) -> Local {
        let b = &self.bits;
        if self.ready.load(Ordering::Acquire) {
            let v = |k: usize| f64::from_bits(b[k].load(Ordering::Relaxed));
            return Local {
                cx: v(0),
                cy: v(1),
                nx: v(2),
                ny: v(3),
            };
        }
        let l = fit();
        for (slot, v) in b.iter().zip([l.cx, l.cy, l.nx, l.ny]) {
            slot.store(v.to_bits(), Ordering::Relaxed);
        }
        self.ready.store(true, Ordering::Release);
        l
    }
}

impl<'a> Target<'a> {
    /// Build the target from the ground truth's frame, its nearest-occupied-cell queries,
    /// and the occupied cells.
    pub fn new(
        frame: Frame,
        columns: &'a dyn NearestCell,
        occupied: &'a [bool],
        cells: &'a [u32],
    ) -> Result<Self, EdtError> {
        Self::with(frame, columns, Occupied::Mask(occupied), cells)
    }

    /// [`Target::new`] with the occupied cells given as a mask or as bits.
    pub fn with(
        frame: Frame,
        columns: &'a dyn NearestCell,
        occupied: Occupied<'a>,
        cells: &'a [u32],
    ) -> Result<Self, EdtError> {
        let mut row_start = vec![0u32; frame.height + 1];
        for &i in cells {
            row_start[i as usize / frame.width + 1] += 1;
        }
        for r in 0..frame.height {
            row_start[r + 1] += row_start[r];
        }
        let mut local = Vec::new();
        local
            .try_reserve_exact(cells.len())
            .map_err(|_| EdtError::Alloc {
                bytes: cells.len().saturating_mul(std::mem::size_of::<Slot>()),
            })?;
        local.resize_with(cells.len(), Slot::default);
        Ok(Target {
            row_start,
            frame,
            to_cell: frame.world_to_cell_affine(),
            top: (
                (frame.height as i64 - 1) as f64,
                (frame.width as i64 - 1) as f64,
            ),
            to_world: frame.cell_to_world(),
            columns,
            dense: columns.as_columns(),
            occupied,
            local,
            cells,
        })
    }

    /// The local shape around occupied cell `cells[k]`, fitted when first asked for.
    fn local(&self, k: usize) -> Local {
        self.local[k].get_or_fit(|| self.fit(self.cells[k]))
    }

    /// Fit a line to the occupied cells of the window around cell `i`.
    fn fit(&self, i: u32) -> Local {
        let frame = &self.frame;
        let (h, w) = (frame.height as isize, frame.width as isize);
        let (r0, c0) = ((i as isize) / w, (i as isize) % w);
        let Scatter {
            n,
            mx,
            my,
            a,
            b,
            d,
            big,
            small,
        } = match self.occupied {
            Occupied::Mask(m) => scatter(m, h, w, r0, c0, LINE_WINDOW),
            Occupied::Bits(b) => scatter_bits(b, r0, c0, LINE_WINDOW),
        };
        let centre = self.to_world.apply(r0 as f64, c0 as f64);
        // the centroid in world coordinates: the centre cell plus the offset
        let (ux, uy) = unit_steps(&self.to_world);
        let cx = centre.0 + mx * ux.0 + my * uy.0;
        let cy = centre.1 + mx * ux.1 + my * uy.1;
        if n >= 3.0 && big > 0.0 && small <= LINE_RATIO * big {
            // normal: the eigenvector of the small eigenvalue, in (x=col, y=row)
            let (ex, ey) = if b.abs() > 1e-12 {
                (small - d, b)
            } else if a <= d {
                (1.0, 0.0)
            } else {
                (0.0, 1.0)
            };
            let wx = ex * ux.0 + ey * uy.0;
            let wy = ex * ux.1 + ey * uy.1;
            let norm = wx.hypot(wy);
            Local {
                cx,
                cy,
                nx: wx / norm,
                ny: wy / norm,
            }
        } else {
            Local {
                cx: centre.0,
                cy: centre.1,
                nx: 0.0,
                ny: 0.0,
            }
        }
    }

    /// The cell (row, column) holding world point `(x, y)` (clamped onto the grid for
    /// points outside it).
    #[inline]
    fn cell_of(&self, x: f64, y: f64) -> (usize, usize) {
        let (r, c) = self.to_cell.apply(x, y);
        (
            floor_clamp_top(r, self.top.0),
            floor_clamp_top(c, self.top.1),
        )
    }

    /// The occupied target cell nearest to cell `(r, c)` (from [`Target::cell_of`]): its
    /// position in `cells` and its centre.
    #[inline]
    fn nearest(&self, r: usize, c: usize) -> Option<(usize, (f64, f64))> {
        let w = self.frame.width;
        let (row, col) = match self.dense {
            Some(columns) => columns.nearest_cell(r, c)?,
            None => {
                let (n, _) = self.columns.query(r, c)?;
                (n as usize / w, n as usize % w)
            }
        };
        let (a, b) = (
            self.row_start[row] as usize,
            self.row_start[row + 1] as usize,
        );
        // fits u32: the cell's index (checked by the column pass)
        let n = (row * w + col) as u32;
        let k = a + self.cells[a..b].binary_search(&n).ok()?;
        Some((k, self.to_world.apply(row as f64, col as f64)))
    }

    /// World centroid of the occupied cells (None when there is none).
    pub fn centroid(&self) -> Option<(f64, f64)> {
        if self.cells.is_empty() {
            return None;
        }
        let w = self.frame.width;
        let (mut sx, mut sy) = (0.0, 0.0);
        for &i in self.cells {
            let (x, y) = self
                .to_world
                .apply((i as usize / w) as f64, (i as usize % w) as f64);
            sx += x;
            sy += y;
        }
        let n = self.cells.len() as f64;
        Some((sx / n, sy / n))
    }
}

/// `floor_i64(x).clamp(0, max)` (NaN: 0) for `0 <= max < 2^53`, without the saturating
/// cast's range checks: the value is clamped first, where truncation is the floor.
#[cfg(test)]
fn floor_clamp(x: f64, max: i64) -> usize {
    floor_clamp_top(x, max as f64)
}

/// [`floor_clamp`] with `max` given as a float (`top = max as f64`, exact), converted once
/// per target instead of per point.
#[inline]
fn floor_clamp_top(x: f64, top: f64) -> usize {
    let x = if x >= 0.0 { x } else { 0.0 };
    let x = if x <= top { x } else { top };
    // SAFETY: 0 <= x <= max < 2^53, finite, inside i64's range
    unsafe { x.to_int_unchecked::<i64>() as usize }
}

/// World displacement of one column step and of one row step.
fn unit_steps(to_world: &Affine) -> ((f64, f64), (f64, f64)) {
    let m = &to_world.m;
    ((m[0][1], m[1][1]), (m[0][0], m[1][0]))
}

/// One correspondence: squared distance to the target cell's centre, the target's position
/// in `Target::cells` (`usize::MAX`: none), and the moved point.
type Pair = (f64, usize, (f64, f64));

/// Per point, the target cell it fell in at the last iteration ([`usize::MAX`]: none yet)
/// and that cell's [`Target::nearest`]: a point that stays in its cell (most, once the
/// steps are small) needs no new query. The position and centre are stored as they are
/// (no `Option`), `usize::MAX` as the position when there is none.
type Memo = (usize, usize, (f64, f64));

/// The correspondence of every point at `t`.
fn correspondences(
    points: &[(f64, f64)],
    target: &Target,
    t: &Se2,
    out: &mut [Pair],
    memo: &mut [Memo],
) {
    let t = t.affine();
    out.par_chunks_mut(CHUNK)
        .zip(memo.par_chunks_mut(CHUNK))
        .zip(points.par_chunks(CHUNK))
        .for_each(|((o, m), p)| {
            for ((slot, memo), &(x, y)) in o.iter_mut().zip(m).zip(p) {
                let q = t.apply(x, y);
                let (r, c) = target.cell_of(q.0, q.1);
                let cell = r * target.frame.width + c;
                if memo.0 != cell {
                    *memo = match target.nearest(r, c) {
                        Some((k, g)) => (cell, k, g),
                        None => (cell, usize::MAX, (0.0, 0.0)),
                    };
                }
                let (k, g) = (memo.1, memo.2);
                let d = (q.0 - g.0).powi(2) + (q.1 - g.1).powi(2);
                *slot = (if k == usize::MAX { f64::INFINITY } else { d }, k, q);
            }
        });
}

/// `x`'s place in [`f64::total_cmp`]'s order, as an unsigned integer.
#[inline]
fn order_key(x: f64) -> u64 {
    let b = x.to_bits();
    b ^ ((((b as i64) >> 63) as u64) >> 1) ^ (1 << 63)
}

/// The `k`-th smallest (from 0) of `keys` (`k < keys.len()`) and how many keys are below it.
/// Larger sets by a sample: every [`SAMPLE_STRIDE`]-th key, sorted, gives two keys
/// `lo <= hi` around the `k`-th's place; one pass counts the keys below `lo` and gathers
/// those in `[lo, hi]`, and when the `k`-th is among them it is selected there, and the
/// keys below it are those below `lo` and the gathered ones below it (else it is selected
/// from all the keys, which are then counted). `buf` is work space.
fn kth_smallest(keys: &[u64], k: usize, buf: &mut Vec<u64>) -> (u64, usize) {
    let n = keys.len();
    buf.clear();
    if n >= 16 * SAMPLE_STRIDE {
        buf.extend(keys.iter().step_by(SAMPLE_STRIDE));
        buf.sort_unstable();
        let m = buf.len();
        let margin = 3 * (m as f64).sqrt() as usize + 4;
        let at = k * m / n;
        let lo = if at > margin { buf[at - margin] } else { 0 };
        let hi = if at + margin < m {
            buf[at + margin]
        } else {
            u64::MAX
        };
        buf.clear();
        let mut less = 0usize;
        for &x in keys {
            if x < lo {
                less += 1;
            } else if x <= hi {
                buf.push(x);
            }
        }
        // the keys below `lo` come first in the order, then those in [lo, hi]
        if less <= k && k < less + buf.len() {
            let thr = *buf.select_nth_unstable(k - less).1;
            return (thr, less + buf.iter().filter(|&&x| x < thr).count());
        }
        buf.clear();
    }
    buf.extend_from_slice(keys);
    let thr = *buf.select_nth_unstable(k).1;
    (thr, keys.iter().filter(|&&x| x < thr).count())
}

/// Every this many keys make [`kth_smallest`]'s sample.
const SAMPLE_STRIDE: usize = 16;

/// The indices, ascending, of the `keep` smallest distances (by [`f64::total_cmp`]; ties at
/// the threshold: the lowest indices). `keys` and `buf` are work space.
fn trimmed(
    res: &[Pair],
    keep: usize,
    order: &mut Vec<u32>,
    keys: &mut Vec<u64>,
    buf: &mut Vec<u64>,
) {
    order.clear();
    if keep >= res.len() {
        order.extend(0..res.len() as u32);
        return;
    }
    keys.clear();
    keys.extend(res.iter().map(|p| order_key(p.0)));
    let (thr, below) = kth_smallest(keys, keep - 1, buf);
    let mut ties = keep - below;
    for (i, &k) in keys.iter().enumerate() {
        if k < thr {
            order.push(i as u32);
        } else if k == thr && ties > 0 {
            ties -= 1;
            order.push(i as u32);
        }
    }
}

/// One Gauss-Newton step of the kept pairs: the small motion `(dtheta about (ox, oy), dx,
/// dy)` minimising the point-to-line and point-to-point residuals, as an [`Se2`], and the
/// size of the step (radians, and metres of the kept points' centroid).
fn step(res: &[Pair], order: &[u32], target: &Target) -> Option<(Se2, f64, f64)> {
    let o = centroid(res, order);
    // normal equations J^T J x = -J^T r, x = (dtheta, dx, dy)
    let mut a = [[0.0f64; 3]; 3];
    let mut g = [0.0f64; 3];
    // the upper triangle only: a[v][u] would sum the same products (j[v] * j[u] ==
    // j[u] * j[v]) in the same order, so it is a[u][v], copied after the loop
    residuals(res, order, target, o, |j, r| {
        for u in 0..3 {
            for v in u..3 {
                a[u][v] += j[u] * j[v];
            }
            g[u] -= j[u] * r;
        }
    });
    for u in 0..3 {
        for v in 0..u {
            a[u][v] = a[v][u];
        }
    }
    Some(motion(solve3(a, g)?, o))
}

/// The centroid of the kept pairs' moved points.
fn centroid(res: &[Pair], order: &[u32]) -> (f64, f64) {
    let n = order.len() as f64;
    let (ox, oy) = order.iter().fold((0.0, 0.0), |(a, b), &i| {
        let q = res[i as usize].2;
        (a + q.0, b + q.1)
    });
    (ox / n, oy / n)
}

/// Each residual of the kept pairs and its Jacobian row `d r / d (dtheta about o, dx, dy)`,
/// in order: one point-to-line residual where the target cell has a line, else the two
/// point-to-point ones.
#[inline(always)]
fn residuals(
    res: &[Pair],
    order: &[u32],
    target: &Target,
    (ox, oy): (f64, f64),
    mut add: impl FnMut([f64; 3], f64),
) {
    for &i in order {
        let (_, k, q) = res[i as usize];
        let l = target.local(k);
        let (px, py) = (q.0 - ox, q.1 - oy);
        // d q / d theta = (-py, px)
        if l.nx != 0.0 || l.ny != 0.0 {
            let r = l.nx * (q.0 - l.cx) + l.ny * (q.1 - l.cy);
            add([l.nx * -py + l.ny * px, l.nx, l.ny], r);
        } else {
            add([-py, 1.0, 0.0], q.0 - l.cx);
            add([px, 0.0, 1.0], q.1 - l.cy);
        }
    }
}

/// The solution `x = (dtheta, dx, dy)` about `o` as an [`Se2`] (q -> R (q - o) + o + d),
/// with the size of the step (radians, metres).
fn motion(x: [f64; 3], (ox, oy): (f64, f64)) -> (Se2, f64, f64) {
    let (s, c) = x[0].sin_cos();
    let m = Se2 {
        theta: x[0],
        tx: ox + x[1] - (c * ox - s * oy),
        ty: oy + x[2] - (s * ox + c * oy),
    };
    (m, x[0].abs(), x[1].hypot(x[2]))
}

/// Solve a 3x3 symmetric system by Gaussian elimination with partial pivoting; None when
/// singular.
fn solve3(mut a: [[f64; 3]; 3], mut b: [f64; 3]) -> Option<[f64; 3]> {
    let scale = a.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    if scale == 0.0 {
        return None;
    }
    for col in 0..3 {
        let p = (col..3).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[p][col].abs() <= 1e-12 * scale {
            return None;
        }
        a.swap(col, p);
        b.swap(col, p);
        for row in col + 1..3 {
            let f = a[row][col] / a[col][col];
            for k in col..3 {
                a[row][k] -= f * a[col][k];
            }
            b[row] -= f * b[col];
        }
    }
    let mut x = [0.0; 3];
    for row in (0..3).rev() {
        let s: f64 = (row + 1..3).map(|k| a[row][k] * x[k]).sum();
        x[row] = (b[row] - s) / a[row][row];
    }
    Some(x)
}

/// Trimmed ICP of `points` (world coordinates) onto `target`, from `start`.
///
/// Each iteration pairs every point (moved by the current motion) with the target's nearest
/// occupied cell, drops the `trim` share farthest from their cell, and takes one
/// Gauss-Newton step of the point-to-line / point-to-point residuals of the kept pairs. It
/// runs on an even subsample of at most [`COARSE_POINTS`] points until a step moves no
/// point by more than half a target cell, then on at most [`MAX_POINTS`] points until a step
/// moves none by more than 0.05 cells, `max_iterations` in all. None when there is no point or the target has no occupied cell.
pub fn icp(
    points: &[(f64, f64)],
    target: &Target,
    start: Se2,
    trim: f64,
    max_iterations: usize,
) -> Option<IcpResult> {
    if points.is_empty() || target.cells.is_empty() {
        return None;
    }
    // coarse to fine: a small subsample until steps are under half a cell, then the full
    // (sub)sample to the final tolerance
    let coarse = run(
        &subsample(points, COARSE_POINTS),
        target,
        start,
        trim,
        max_iterations,
        EPS_COARSE,
        false,
    )?;
    let left = max_iterations.saturating_sub(coarse.iterations);
    let fine = run(
        &subsample(points, MAX_POINTS),
        target,
        coarse.transform,
        trim,
        left,
        EPS_MOVE,
        true,
    )?;
    Some(IcpResult {
        iterations: coarse.iterations + fine.iterations,
        ..fine
    })
}

/// An even subsample (every k-th point) of at most `n` points.
fn subsample(points: &[(f64, f64)], n: usize) -> Vec<(f64, f64)> {
    let stride = points.len().div_ceil(n).max(1);
    points.iter().step_by(stride).copied().collect()
}

/// The ICP loop on `points`, until a step moves no point by more than `eps_cells`. With
/// `final_rms` false (the coarse stage, whose transform and iterations alone are used) the
/// pairs are not formed again at the converged transform: its `rms` is then the last
/// iteration's, before its step.
fn run(
    points: &[(f64, f64)],
    target: &Target,
    start: Se2,
    trim: f64,
    max_iterations: usize,
    eps_cells: f64,
    final_rms: bool,
) -> Option<IcpResult> {
    let keep = (((1.0 - trim) * points.len() as f64).ceil() as usize).clamp(1, points.len());
    let mut res: Vec<Pair> = vec![(0.0, 0, (0.0, 0.0)); points.len()];
    let mut memo: Vec<Memo> = vec![(usize::MAX, usize::MAX, (0.0, 0.0)); points.len()];
    let mut order = Vec::with_capacity(points.len());
    let mut t = start;
    let mut iterations = 0;
    let eps = eps_cells * target.frame.resolution;
    // the largest distance of a point from the points' centroid: a turn of a radians about
    // the centroid moves no point by more than a * radius
    let n = points.len() as f64;
    let (cx, cy) = points
        .iter()
        .fold((0.0, 0.0), |(a, b), p| (a + p.0 / n, b + p.1 / n));
    let radius = radius(points, cx, cy);
    let (mut keys, mut buf) = (Vec::with_capacity(points.len()), Vec::new());
    loop {
        correspondences(points, target, &t, &mut res, &mut memo);
        trimmed(&res, keep, &mut order, &mut keys, &mut buf);
        let rms = (order.iter().map(|&i| res[i as usize].0).sum::<f64>() / keep as f64).sqrt();
        let done = |t: Se2, iterations: usize| IcpResult {
            transform: t,
            rms,
            iterations,
            inliers: keep,
        };
        if iterations >= max_iterations {
            return Some(done(t, iterations));
        }
        let Some((delta, turn, shift)) = step(&res, &order, target) else {
            return Some(done(t, iterations));
        };
        iterations += 1;
        // `shift` is measured at the kept points' centroid, within `radius` of every point
        let converged = turn * radius + shift < eps;
        t = delta.compose(&t);
        if converged && !final_rms {
            return Some(done(t, iterations));
        }
        if converged {
            correspondences(points, target, &t, &mut res, &mut memo);
            trimmed(&res, keep, &mut order, &mut keys, &mut buf);
            let rms = (order.iter().map(|&i| res[i as usize].0).sum::<f64>() / keep as f64).sqrt();
            return Some(IcpResult {
                transform: t,
                rms,
                iterations,
                inliers: keep,
            });
        }
    }
}

/// The largest `hypot` of the points' offsets from `(cx, cy)` (0 with none; NaN offsets
/// skipped, as `f64::max` does): `hypot` only of the points whose squared offset is within
/// 1e-6 (relative) of the largest. Exact: a squared offset is within 3 ulp of the exact one
/// and `hypot` within 1 ulp of its root, so a point left out is below the largest one's
/// exact norm by more than both errors, and its `hypot` below that point's. Offsets whose
/// squares could leave the normal range (or NaN, infinite) take every `hypot`.
fn radius(points: &[(f64, f64)], cx: f64, cy: f64) -> f64 {
    let all = || {
        points
            .iter()
            .map(|p| (p.0 - cx).hypot(p.1 - cy))
            .fold(0.0, f64::max)
    };
    let mut top = 0.0f64;
    for p in points {
        let (dx, dy) = (p.0 - cx, p.1 - cy);
        let s = dx * dx + dy * dy;
        if s.is_nan() || s > 1e200 {
            return all();
        }
        top = top.max(s);
    }
    if top < 1e-200 {
        return all();
    }
    let bar = top * (1.0 - 1e-6);
    points
        .iter()
        .filter(|p| {
            let (dx, dy) = (p.0 - cx, p.1 - cy);
            dx * dx + dy * dy >= bar
        })
        .map(|p| (p.0 - cx).hypot(p.1 - cy))
        .fold(0.0, f64::max)
}

/// The scatter of the occupied cells in the square window of half-size `half` around cell
/// (`r0`, `c0`) of a `h` x `w` mask, in window coordinates relative to the centre cell
/// (x = column, y = row, in cells): their count `n`, centroid (`mx`, `my`), covariance
/// `[[a, b], [b, d]]` and its eigenvalues `big >= small`. Cells are summed row by row, so
/// the figures are the same wherever they are asked for. With `n == 0` they are NaN.
pub(crate) struct Scatter {
    pub n: f64,
    pub mx: f64,
    pub my: f64,
    pub a: f64,
    pub b: f64,
    pub d: f64,
    pub big: f64,
    pub small: f64,
}

/// [`Scatter`] of one window (a local line fit: ICP's point-to-line targets, the
/// registration's wall directions).
pub(crate) fn scatter(
    occupied: &[bool],
    h: isize,
    w: isize,
    r0: isize,
    c0: isize,
    half: isize,
) -> Scatter {
    let (mut n, mut sx, mut sy, mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for r in (r0 - half).max(0)..=(r0 + half).min(h - 1) {
        let row = &occupied[(r * w) as usize..((r + 1) * w) as usize];
        for c in (c0 - half).max(0)..=(c0 + half).min(w - 1) {
            if row[c as usize] {
                let (x, y) = ((c - c0) as f64, (r - r0) as f64);
                n += 1.0;
                sx += x;
                sy += y;
                sxx += x * x;
                sxy += x * y;
                syy += y * y;
            }
        }
    }
    scatter_of(n, sx, sy, sxx, sxy, syy)
}

/// [`scatter`] of the set cells of `bits`, read a column of the window at a time: the same
/// figures (every sum is of small integers: summed exactly as integers here, they are the
/// mask's floating sums, which are exact in any order and start at +0, so none is -0).
pub(crate) fn scatter_bits(bits: &Sparse, r0: isize, c0: isize, half: isize) -> Scatter {
    let w = bits.width as isize;
    let (mut n, mut sx, mut sy, mut sxx, mut sxy, mut syy) = (0i64, 0i64, 0i64, 0i64, 0i64, 0i64);
    let len = (2 * half + 1) as u32;
    let h = half as i64;
    for c in (c0 - half).max(0)..=(c0 + half).min(w - 1) {
        let m = bits.column_bits(c as usize, r0 - half, len);
        if m == 0 {
            continue;
        }
        // the set bits' places t (row r0 - half + t): count, sum, sum of squares; then
        // about the centre row (y = t - half)
        let (k, s1, s2) = moments(m);
        let (ky, kyy) = (s1 - h * k, s2 - 2 * h * s1 + h * h * k);
        let x = (c - c0) as i64;
        n += k;
        sx += x * k;
        sy += ky;
        sxx += x * x * k;
        sxy += x * ky;
        syy += kyy;
    }
    let f = |v: i64| v as f64;
    scatter_of(f(n), f(sx), f(sy), f(sxx), f(sxy), f(syy))
}

/// Count, sum and sum of squares of the places of the set bits of `m`: from a table for
/// seven bits or fewer (windows of half-size up to 3).
#[inline]
fn moments(m: u64) -> (i64, i64, i64) {
    const TABLE: [(u8, u8, u8); 128] = {
        let mut t = [(0u8, 0u8, 0u8); 128];
        let mut m = 0;
        while m < 128 {
            let mut b = 0;
            while b < 7 {
                if (m >> b) & 1 == 1 {
                    t[m].0 += 1;
                    t[m].1 += b as u8;
                    t[m].2 += (b * b) as u8;
                }
                b += 1;
            }
            m += 1;
        }
        t
    };
    if m < 128 {
        let (k, s1, s2) = TABLE[m as usize];
        return (k as i64, s1 as i64, s2 as i64);
    }
    let (mut k, mut s1, mut s2, mut b) = (0i64, 0i64, 0i64, m);
    while b != 0 {
        let t = b.trailing_zeros() as i64;
        b &= b - 1;
        k += 1;
        s1 += t;
        s2 += t * t;
    }
    (k, s1, s2)
}

/// [`Scatter`] from the count and the sums of the window's cells.
fn scatter_of(n: f64, sx: f64, sy: f64, sxx: f64, sxy: f64, syy: f64) -> Scatter {
    let (mx, my) = (sx / n, sy / n);
    let (a, b, d) = (sxx / n - mx * mx, sxy / n - mx * my, syy / n - my * my);
    let mid = 0.5 * (a + d);
    let root = (0.25 * (a - d) * (a - d) + b * b).sqrt();
    Scatter {
        n,
        mx,
        my,
        a,
        b,
        d,
        big: mid + root,
        small: mid - root,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::edt::tests::rng;
    use crate::se2::floor_i64;

    /// The occupied cells of `mask` (`h x w`, row-major), their bits and column pass, and a
    /// 0.05 m frame of the grid at `origin`.
    fn target_parts(
        mask: &[bool],
        h: usize,
        w: usize,
        origin: Se2,
    ) -> (Vec<u32>, Sparse, Columns, Frame) {
        let cells: Vec<u32> = (0..h * w).filter(|&i| mask[i]).map(|i| i as u32).collect();
        let bits = Sparse::new(&cells, h, w).unwrap();
        let columns = bits.columns().unwrap();
        let frame = Frame {
            resolution: 0.05,
            height: h,
            width: w,
            origin,
        };
        (cells, bits, columns, frame)
    }

    /// `floor_clamp` is `floor_i64` clamped, on random, edge and special values.
    #[test]
    fn floor_clamp_equals_floor_i64_clamped() {
        let mut next = rng(41);
        let mut xs = vec![
            0.0,
            -0.0,
            f64::NAN,
            -f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            1e300,
            -1e300,
            9.2e18,
            -9.3e18,
            0.999_999_999_999_999_9,
            -1e-300,
        ];
        for _ in 0..20000 {
            let m = (next() % 2000) as f64;
            xs.push((next() % 4_000_000) as f64 / 1000.0 - m);
            xs.push(f64::from_bits(next()));
        }
        for max in [0i64, 1, 7, 999, 1_000_000, (1 << 52) - 1] {
            for &x in &xs {
                let x2 = x + max as f64 * (x.abs() < 10.0) as i64 as f64;
                for v in [x, x2, max as f64, max as f64 - 1e-9, max as f64 + 0.5] {
                    assert_eq!(
                        floor_clamp(v, max) as i64,
                        floor_i64(v).clamp(0, max),
                        "{v} {max}"
                    );
                }
            }
        }
    }

    /// The former trimming: a copy of the distances selected by `total_cmp`.
    fn trimmed_literal(res: &[Pair], keep: usize) -> Vec<u32> {
        if keep >= res.len() {
            return (0..res.len() as u32).collect();
        }
        let mut d: Vec<f64> = res.iter().map(|p| p.0).collect();
        let (_, &mut thr, _) = d.select_nth_unstable_by(keep - 1, |a, b| a.total_cmp(b));
        let below = res.iter().filter(|p| p.0.total_cmp(&thr).is_lt()).count();
        let mut ties = keep - below;
        let mut order = Vec::new();
        for (i, p) in res.iter().enumerate() {
            match p.0.total_cmp(&thr) {
                std::cmp::Ordering::Less => order.push(i as u32),
                std::cmp::Ordering::Equal if ties > 0 => {
                    ties -= 1;
                    order.push(i as u32);
                }
                _ => {}
            }
        }
        order
    }

    /// The sampled selection keeps the literal one's indices: random distances (few
    /// distinct values, many ties, infinities, NaN and -0), sizes 1-9000, every trim.
    #[test]
    fn trimmed_equals_the_literal_selection() {
        let mut next = rng(43);
        let (mut order, mut keys, mut buf) = (Vec::new(), Vec::new(), Vec::new());
        for case in 0..400 {
            let n = 1 + (next() % [20, 300, 3000, 9000][case % 4]) as usize;
            let kind = case % 5;
            let res: Vec<Pair> = (0..n)
                .map(|_| {
                    let x = next();
                    let d = match kind {
                        0 => (x % 1_000_000) as f64 * 1e-9,
                        1 => (x % 7) as f64,
                        2 => [0.0, -0.0, f64::INFINITY, f64::NAN, -f64::NAN, 1.5][(x % 6) as usize],
                        3 => f64::from_bits(x),
                        _ => {
                            ((x % 1000) as f64 * 1e-3).powi(2) + if x % 97 == 0 { 1e3 } else { 0.0 }
                        }
                    };
                    (d, 0, (0.0, 0.0))
                })
                .collect();
            for keep in [1, n / 3 + 1, (n * 4).div_ceil(5), n - 1, n] {
                let keep = keep.clamp(1, n);
                trimmed(&res, keep, &mut order, &mut keys, &mut buf);
                assert_eq!(
                    order,
                    trimmed_literal(&res, keep),
                    "case {case} n {n} keep {keep}"
                );
            }
        }
    }

    /// The cached fits, asked for by several threads at once (each cell many times), are
    /// the fits themselves, bit for bit.
    #[test]
    fn cached_fits_equal_the_fits() {
        let mut next = rng(47);
        let (h, w) = (90usize, 70usize);
        let mask: Vec<bool> = (0..h * w).map(|i| i % 7 == 0 || next() % 9 == 0).collect();
        let origin = Se2 {
            theta: 0.3,
            tx: 1.0,
            ty: -2.0,
        };
        let (cells, bits, columns, frame) = target_parts(&mask, h, w, origin);
        let target = Target::with(frame, &columns, Occupied::Bits(&bits), &cells).unwrap();
        let want: Vec<[u64; 4]> = cells
            .iter()
            .map(|&i| {
                let l = target.fit(i);
                [l.cx, l.cy, l.nx, l.ny].map(f64::to_bits)
            })
            .collect();
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(4)
            .build()
            .unwrap();
        let got: Vec<Vec<[u64; 4]>> = pool.install(|| {
            (0..8)
                .into_par_iter()
                .map(|t| {
                    (0..cells.len())
                        .map(|k| {
                            let k = (k + t * 13) % cells.len();
                            let l = target.local(k);
                            (k, [l.cx, l.cy, l.nx, l.ny].map(f64::to_bits))
                        })
                        .fold(vec![[0u64; 4]; cells.len()], |mut v, (k, b)| {
                            v[k] = b;
                            v
                        })
                })
                .collect()
        });
        for g in got {
            assert_eq!(g, want);
        }
    }

    /// The direct column queries (`Columns::nearest_cell`) and the trait's (`Sparse`, the
    /// cell index divided) give every cell the same target cell and centre.
    #[test]
    fn direct_queries_equal_the_trait_queries() {
        let mut next = rng(61);
        for case in 0..40 {
            let (h, w) = (1 + (next() % 80) as usize, 1 + (next() % 120) as usize);
            let density = [1u64, 5, 40, 300][case % 4];
            let mask: Vec<bool> = (0..h * w).map(|_| next() % 1000 < density).collect();
            let origin = Se2 {
                theta: -0.7,
                tx: 3.0,
                ty: 0.5,
            };
            let (cells, bits, columns, frame) = target_parts(&mask, h, w, origin);
            let direct = Target::with(frame, &columns, Occupied::Bits(&bits), &cells).unwrap();
            let other = Target::with(frame, &bits, Occupied::Bits(&bits), &cells).unwrap();
            assert!(direct.dense.is_some() && other.dense.is_none());
            for r in 0..h {
                for c in 0..w {
                    let (a, b) = (direct.nearest(r, c), other.nearest(r, c));
                    assert_eq!(a.map(|(k, _)| k), b.map(|(k, _)| k), "{h}x{w} ({r}, {c})");
                    let bits = |p: Option<(usize, (f64, f64))>| {
                        p.map(|(_, g)| (g.0.to_bits(), g.1.to_bits()))
                    };
                    assert_eq!(bits(a), bits(b));
                }
            }
        }
    }

    /// The former step: the whole matrix summed.
    fn step_literal(res: &[Pair], order: &[u32], target: &Target) -> Option<(Se2, f64, f64)> {
        let o = centroid(res, order);
        let mut a = [[0.0f64; 3]; 3];
        let mut g = [0.0f64; 3];
        residuals(res, order, target, o, |j, r| {
            for u in 0..3 {
                for v in 0..3 {
                    a[u][v] += j[u] * j[v];
                }
                g[u] -= j[u] * r;
            }
        });
        Some(motion(solve3(a, g)?, o))
    }

    /// The step from the upper triangle equals the whole matrix's, bit for bit, on random
    /// pairs (lines and corners) and kept subsets.
    #[test]
    fn step_equals_the_literal_step() {
        let mut next = rng(67);
        let (h, w) = (60usize, 50usize);
        let mask: Vec<bool> = (0..h * w).map(|i| i % 11 == 0 || next() % 7 == 0).collect();
        let origin = Se2 {
            theta: 0.4,
            tx: -1.0,
            ty: 2.0,
        };
        let (cells, bits, columns, frame) = target_parts(&mask, h, w, origin);
        let target = Target::with(frame, &columns, Occupied::Bits(&bits), &cells).unwrap();
        let unit = |x: u64| (x % 1_000_000) as f64 * 1e-6;
        for case in 0..300 {
            let n = 1 + (next() % [3, 40, 2000][case % 3]) as usize;
            let res: Vec<Pair> = (0..n)
                .map(|_| {
                    let q = (unit(next()) * 4.0 - 2.0, unit(next()) * 3.0 + 1.0);
                    (unit(next()), (next() % cells.len() as u64) as usize, q)
                })
                .collect();
            let order: Vec<u32> = (0..n as u32).filter(|_| next() % 5 != 0).collect();
            let order = if order.is_empty() { vec![0] } else { order };
            let bits = |s: Option<(Se2, f64, f64)>| {
                s.map(|(t, a, b)| [t.theta, t.tx, t.ty, a, b].map(f64::to_bits))
            };
            assert_eq!(
                bits(step(&res, &order, &target)),
                bits(step_literal(&res, &order, &target)),
                "case {case}"
            );
        }
    }

    /// The radius from the largest squared offsets equals every `hypot`'s maximum: random
    /// clouds, ties (mirrored points), one point, huge and tiny offsets, NaN.
    #[test]
    fn radius_equals_every_hypot() {
        let mut next = rng(71);
        let unit = |x: u64| (x % 1_000_000_007) as f64 / 1_000_000_007.0;
        for case in 0..400 {
            let n = 1 + (next() % [1, 5, 100, 5000][case % 4]) as usize;
            let scale = [1.0, 1e-3, 50.0, 1e-160, 1e160, 1e-100][case % 6];
            let mut pts: Vec<(f64, f64)> = (0..n)
                .map(|_| ((unit(next()) - 0.5) * scale, (unit(next()) - 0.5) * scale))
                .collect();
            if case % 5 == 0 {
                let m: Vec<(f64, f64)> = pts.iter().map(|p| (-p.1, p.0)).collect();
                pts.extend(m);
            }
            if case % 37 == 0 {
                pts.push((f64::NAN, 0.0));
            }
            let (cx, cy) = ([0.0, 0.1 * scale][case % 2], 0.0);
            let want = pts
                .iter()
                .map(|p| (p.0 - cx).hypot(p.1 - cy))
                .fold(0.0, f64::max);
            assert_eq!(
                radius(&pts, cx, cy).to_bits(),
                want.to_bits(),
                "case {case}"
            );
        }
    }

    fn bits_of(s: &Scatter) -> [u64; 8] {
        [s.n, s.mx, s.my, s.a, s.b, s.d, s.big, s.small].map(f64::to_bits)
    }

    /// The window read from the bits gives the mask's figures bit for bit, at every cell of
    /// random masks (edges, tall grids crossing 64-row words, sparse and dense).
    #[test]
    fn scatter_bits_equals_scatter() {
        let mut next = rng(27);
        for case in 0..60 {
            let h = 1 + (next() % if case % 3 == 0 { 150 } else { 20 }) as usize;
            let w = 1 + (next() % 20) as usize;
            let density = 1 + next() % 6;
            let mask: Vec<bool> = (0..h * w).map(|_| next() % 8 < density).collect();
            let cells: Vec<u32> = (0..h * w).filter(|&i| mask[i]).map(|i| i as u32).collect();
            let bits = Sparse::new(&cells, h, w).unwrap();
            for half in [1isize, 2, 3, 4] {
                for r in 0..h as isize {
                    for c in 0..w as isize {
                        let a = scatter(&mask, h as isize, w as isize, r, c, half);
                        let b = scatter_bits(&bits, r, c, half);
                        assert_eq!(bits_of(&a), bits_of(&b), "{h}x{w} ({r}, {c}) half {half}");
                    }
                }
            }
        }
    }
}
