//! Global registration of one occupancy map onto another (SPEC section 7a): the rigid motion
//! (any rotation, any translation) taking the moving map's world frame onto the fixed map's,
//! for maps of one place made by different SLAM programs (other resolution, origin, yaw,
//! extent, completeness).
//!
//! 1. Each map once ([`prepare`]): its occupied cells as world points, its nearest-wall
//!    queries ([`Columns`]), and a histogram of its wall directions (mod 180 degrees, 1-degree
//!    bins): each occupied cell's neighbours within [`WINDOW`] cells fitted with a line,
//!    weighted by how line-like they are.
//! 2. Rotations: the circular cross-correlation of the two histograms; its best
//!    [`ROTATION_PEAKS`] peaks, each with its +90, +180 and +270 degree variants.
//! 3. Translation per rotation: the moving walls, turned, rasterised at a coarse common
//!    resolution (at most [`COARSE_CELLS`] cells a side), cross-correlated by FFT with the
//!    fixed walls' coarse raster (2 on a wall cell, 1 beside one): the best
//!    [`TRANSLATION_PEAKS`] shifts per rotation.
//! 4. The [`REFINED`] best candidates by coarse score are refined by a short trimmed ICP on
//!    a subsample and scored by the share of the moving points within the tolerance of a
//!    fixed wall times the consistency of the fixed walls that land on the moving map; the
//!    best is refined by the full ICP.
//! 5. Confidence: both maps' consistency where they overlap, their overlap, and the margin
//!    to the best *distinct* runner-up; the registration is refused (`ok = false`, with a
//!    reason) rather than forced when one of them is too low.
//! 6. When steps 1-5 refuse, the wide search ([`register_prepared`]'s second chance): both
//!    maps on the coarser map's grid, rotations every [`SWEEP_DEG`] degrees, finer coarse
//!    rasters, an ICP robust to partial overlap, runner-ups refined before they count, and
//!    a stricter margin; its answer is kept only when it places the map.
//!
//! Deterministic: candidates are evaluated in parallel but collected and reduced in a fixed
//! order, counts are integers summed per fixed chunk; the FFT runs the same plan for any
//! thread count.

use crate::edt::{filled, Columns, EdtError};
use crate::error::Error;
use crate::grid::Grid;
use crate::icp::{icp, scatter, IcpResult, Scatter, Target};
use crate::se2::{floor_i64, wrap, Affine, Frame, Placed, Se2};
use rayon::prelude::*;
use rustfft::num_complex::Complex;
use rustfft::{Fft, FftPlanner};
use std::sync::Arc;

/// Half-size (cells) of the window whose occupied cells give a wall cell's direction.
pub const WINDOW: isize = 3;
/// Peaks of the rotation correlation kept (each with its 90-degree variants).
pub const ROTATION_PEAKS: usize = 3;
/// A rotation peak is kept when at least this share of the highest one.
const ROTATION_PEAK_SHARE: f64 = 0.3;
/// Rotations closer than this (degrees) are one candidate.
const SAME_ROTATION_DEG: f64 = 3.0;
/// The coarse rasters have at most this many cells a side.
pub const COARSE_CELLS: f64 = 128.0;
/// Shifts kept per rotation.
pub const TRANSLATION_PEAKS: usize = 3;
/// Candidates refined by the short ICP.
pub const REFINED: usize = 6;
/// Points of the candidates' short ICP and score (an even subsample).
const SCORE_POINTS: usize = 1000;
/// Iterations of the candidates' short ICP.
const SHORT_ITERATIONS: usize = 10;
/// Points of the final figures, each way (an even subsample).
const FIGURE_POINTS: usize = 20000;
/// Fewer occupied cells than this: nothing to register.
pub const MIN_POINTS: usize = 20;
/// Counted in fixed chunks (the split does not depend on the thread count).
const CHUNK: usize = 4096;
/// The margin at which the confidence stops growing.
pub const MARGIN_FULL: f64 = 0.5;

/// The wide search (for maps the first search refused) tries rotations every this many
/// degrees, besides the histogram peaks.
pub const SWEEP_DEG: f64 = 3.0;
/// Candidates the wide search refines by the short ICP (at most one per place).
pub const WIDE_REFINED: usize = 16;
/// Share of the pairs the wide search's ICP drops at every iteration (at least the
/// parameters' trim): with half of a map outside the other, a trim of 0.2 leaves the
/// unmatched walls to pull the fit away.
pub const WIDE_TRIM: f64 = 0.5;
/// The wide search's coarse rasters have at most this many cells a side (a small overlap
/// is lost in cells of 0.5 m).
pub const WIDE_COARSE_CELLS: f64 = 256.0;
/// Two motions turning a map by less than this (degrees) apart, its centroid within the
/// distinct distance, put it in one place (the wide search).
pub const SAME_PLACE_DEG: f64 = 10.0;
/// Runner-ups the wide search refines by the full ICP to find one in another place.
pub const RUNNER_TRIES: usize = 4;
/// The wide search places a map only when its best score is at least 1.5 times the
/// runner-up's (margin 1/3, at least the parameters' `min_margin`): it tries 15 times more
/// rotations than the first search, so more wrong motions fit by chance (a symmetric
/// world's half turn passed a margin of 0.05).
pub const WIDE_MIN_MARGIN: f64 = 1.0 / 3.0;

/// Parameters of a registration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RegisterParams {
    /// Occupied: a known cell whose occupancy probability `(255 - v) / 255` is above this.
    pub occupied_threshold: f64,
    /// A point agrees with a map when within this many metres of its walls; None: the
    /// larger of 0.2 m and two cells of the coarser map.
    pub tolerance: Option<f64>,
    /// Refused below this consistency (the worse of the two directions).
    pub min_inliers: f64,
    /// Refused below this overlap (the larger of the two directions).
    pub min_overlap: f64,
    /// Refused below this margin to the best distinct runner-up.
    pub min_margin: f64,
    /// Share of the ICP's correspondences dropped at every iteration.
    pub trim: f64,
    /// At most this many iterations of the final ICP.
    pub max_iterations: usize,
}

impl Default for RegisterParams {
    fn default() -> Self {
        RegisterParams {
            occupied_threshold: 0.5,
            tolerance: None,
            min_inliers: 0.6,
            min_overlap: 0.1,
            min_margin: 0.05,
            trim: 0.2,
            max_iterations: 30,
        }
    }
}

/// One map, prepared once for any number of registrations.
pub struct Prepared<'a> {
    pub frame: Frame,
    unknown: &'a [bool],
    /// World centres of the occupied cells, row-major.
    pub points: Vec<(f64, f64)>,
    mask: Vec<bool>,
    cells: Vec<u32>,
    columns: Columns,
    to_cell: Affine,
    to_world: Affine,
    /// Wall directions mod 180 degrees, 1-degree bins, smoothed; world frame.
    pub histogram: [f64; 180],
}

/// What a registration found.
#[derive(Clone, Debug, PartialEq)]
pub struct Registration {
    /// Whether the transform is to be trusted; `reason` says why not.
    pub ok: bool,
    pub reason: String,
    /// Moving world -> fixed world (identity when no candidate was found).
    pub transform: Se2,
    /// Consistency: of the moving walls that land on the fixed map's known cells (or near
    /// its walls), the share within the tolerance of a fixed wall; and the same the other
    /// way round. `inliers` is the smaller.
    pub inliers: f64,
    pub inliers_moving: f64,
    pub inliers_fixed: f64,
    /// Share of the moving walls landing on the fixed map's known cells, and the other way
    /// round. `overlap` is the larger.
    pub overlap: f64,
    pub overlap_moving: f64,
    pub overlap_fixed: f64,
    /// At the best candidate and at the best distinct runner-up (NaN: none), on the
    /// candidates' subsamples: the share of the moving points within the tolerance of a
    /// fixed wall, times the consistency of the fixed points landing on the moving map.
    pub score: f64,
    pub runner_up_score: f64,
    pub runner_up: Option<Se2>,
    /// `1 - runner_up_score / score` (1 without a distinct runner-up).
    pub margin: f64,
    /// `inliers * min(1, margin / MARGIN_FULL)`, 0 when refused.
    pub confidence: f64,
    /// The final ICP's inlier RMS (metres) and iterations.
    pub icp_rms: f64,
    pub icp_iterations: usize,
    /// Rotations tried, candidates refined.
    pub rotations: usize,
    pub candidates: usize,
    /// The tolerance used, metres.
    pub tolerance: f64,
}

impl Registration {
    fn refused(reason: String, tolerance: f64) -> Self {
        Registration {
            ok: false,
            reason,
            transform: Se2::IDENTITY,
            inliers: 0.0,
            inliers_moving: 0.0,
            inliers_fixed: 0.0,
            overlap: 0.0,
            overlap_moving: 0.0,
            overlap_fixed: 0.0,
            score: 0.0,
            runner_up_score: f64::NAN,
            runner_up: None,
            margin: 0.0,
            confidence: 0.0,
            icp_rms: f64::NAN,
            icp_iterations: 0,
            rotations: 0,
            candidates: 0,
            tolerance,
        }
    }
}

fn check_frame(f: &Frame, what: &str) -> Result<(), Error> {
    let ok = f.resolution.is_finite()
        && f.resolution > 0.0
        && f.origin.theta.is_finite()
        && f.origin.tx.is_finite()
        && f.origin.ty.is_finite();
    if ok {
        Ok(())
    } else {
        Err(Error::Invalid(format!(
            "{what}: resolution must be positive and origin finite"
        )))
    }
}

fn check_params(p: &RegisterParams) -> Result<(), Error> {
    let share = |x: f64| (0.0..=1.0).contains(&x);
    let ok = p.occupied_threshold.is_finite()
        && (0.0..1.0).contains(&p.occupied_threshold)
        && p.tolerance.is_none_or(|t| t.is_finite() && t > 0.0)
        && share(p.min_inliers)
        && share(p.min_overlap)
        && share(p.min_margin)
        && (0.0..1.0).contains(&p.trim);
    if ok {
        Ok(())
    } else {
        Err(Error::Invalid(format!(
            "registration parameters out of range: {p:?}"
        )))
    }
}

/// Prepare one map: occupied points, nearest-wall queries, wall-direction histogram.
pub fn prepare<'a>(
    map: &Placed<'a>,
    occupied_threshold: f64,
    what: &str,
) -> Result<Prepared<'a>, Error> {
    check_frame(&map.frame, what)?;
    let g = &map.grid;
    if map.frame.height != g.height || map.frame.width != g.width {
        return Err(Error::Invalid(format!(
            "{what}: frame size differs from the grid's"
        )));
    }
    let (h, w) = (g.height, g.width);
    let mut occ = [false; 256];
    for (v, o) in occ.iter_mut().enumerate() {
        *o = (255 - v) as f64 / 255.0 > occupied_threshold;
    }
    let mut mask = filled(h * w, false)?;
    let mut cells: Vec<u32> = Vec::new();
    for (i, ((m, &v), &u)) in mask.iter_mut().zip(g.values).zip(g.unknown).enumerate() {
        if !u && occ[v as usize] {
            *m = true;
            if cells.len() == cells.capacity() {
                let more = cells.capacity().max(1024);
                cells.try_reserve(more).map_err(|_| EdtError::Alloc {
                    bytes: (cells.capacity() + more).saturating_mul(4),
                })?;
            }
            cells.push(i as u32);
        }
    }
    let to_world = map.frame.cell_to_world();
    let mut points = Vec::new();
    points
        .try_reserve_exact(cells.len())
        .map_err(|_| EdtError::Alloc {
            bytes: cells.len().saturating_mul(16),
        })?;
    points.extend(
        cells
            .iter()
            .map(|&i| to_world.apply((i as usize / w) as f64, (i as usize % w) as f64)),
    );
    let columns = Columns::new(|i| mask[i], h, w)?;
    let histogram = directions(&mask, &cells, h, w, map.frame.origin.theta);
    Ok(Prepared {
        frame: map.frame,
        unknown: g.unknown,
        points,
        mask,
        cells,
        columns,
        to_cell: map.frame.world_to_cell_affine(),
        to_world,
        histogram,
    })
}

/// The wall-direction histogram: per occupied cell, the line fitted to the occupied cells
/// within [`WINDOW`] cells, its direction (world, mod 180 degrees) split linearly between
/// the two nearest 1-degree bins with weight `1 - small / large` (the eigenvalues of the
/// cells' scatter), then smoothed by a 1-4-6-4-1 binomial.
fn directions(mask: &[bool], cells: &[u32], h: usize, w: usize, yaw: f64) -> [f64; 180] {
    let parts: Vec<[f64; 180]> = cells
        .par_chunks(CHUNK)
        .map(|chunk| {
            let mut hist = [0.0f64; 180];
            for &i in chunk {
                let (r0, c0) = ((i as usize / w) as isize, (i as usize % w) as isize);
                let Scatter {
                    n,
                    a,
                    b,
                    d,
                    big,
                    small,
                    ..
                } = scatter(mask, h as isize, w as isize, r0, c0, WINDOW);
                if n < 3.0 {
                    continue;
                }
                if big <= 0.0 {
                    continue;
                }
                let weight = 1.0 - small.max(0.0) / big;
                // direction of the line in (col, row) cells; rows grow downwards, so the
                // world angle is minus that, plus the map's yaw
                let phi = 0.5 * (2.0 * b).atan2(a - d);
                let deg = (yaw - phi).to_degrees().rem_euclid(180.0);
                let lo = deg.floor();
                let f = deg - lo;
                let lo = lo as usize % 180;
                hist[lo] += weight * (1.0 - f);
                hist[(lo + 1) % 180] += weight * f;
            }
            hist
        })
        .collect();
    let mut hist = [0.0f64; 180];
    for p in parts {
        for (a, b) in hist.iter_mut().zip(p) {
            *a += b;
        }
    }
    let mut out = [0.0f64; 180];
    for (k, o) in out.iter_mut().enumerate() {
        *o = (hist[(k + 178) % 180]
            + 4.0 * hist[(k + 179) % 180]
            + 6.0 * hist[k]
            + 4.0 * hist[(k + 1) % 180]
            + hist[(k + 2) % 180])
            / 16.0;
    }
    out
}

/// Candidate rotations (radians, in [0, 2 pi)) taking the moving walls' directions onto
/// the fixed ones': the peaks of the histograms' circular cross-correlation, each with its
/// 90-degree variants, duplicates (within [`SAME_ROTATION_DEG`]) dropped.
fn rotations(moving: &[f64; 180], fixed: &[f64; 180]) -> Vec<f64> {
    let corr: Vec<f64> = (0..180)
        .map(|k| (0..180).map(|j| moving[j] * fixed[(j + k) % 180]).sum())
        .collect();
    let mut peaks: Vec<(f64, usize)> = (0..180)
        .filter(|&k| {
            let v = corr[k];
            v > 0.0 && v >= corr[(k + 179) % 180] && v > corr[(k + 1) % 180]
        })
        .map(|k| (corr[k], k))
        .collect();
    peaks.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    let top = peaks.first().map_or(0.0, |p| p.0);
    let mut out: Vec<f64> = Vec::new();
    for &(v, k) in peaks.iter().take(ROTATION_PEAKS) {
        if v < ROTATION_PEAK_SHARE * top {
            break;
        }
        // parabolic interpolation of the peak
        let (l, r) = (corr[(k + 179) % 180], corr[(k + 1) % 180]);
        let den = l - 2.0 * v + r;
        let off = if den < 0.0 {
            (0.5 * (l - r) / den).clamp(-0.5, 0.5)
        } else {
            0.0
        };
        let deg = k as f64 + off;
        for q in 0..4 {
            let a = (deg + 90.0 * q as f64).rem_euclid(360.0);
            let close = out.iter().any(|&b| {
                let d = (a - b).rem_euclid(360.0);
                d.min(360.0 - d) < SAME_ROTATION_DEG
            });
            if !close {
                out.push(a);
            }
        }
    }
    out.into_iter().map(f64::to_radians).collect()
}

/// Axis-aligned bounds (min x, min y, max x, max y) of points.
fn bounds(points: &[(f64, f64)]) -> (f64, f64, f64, f64) {
    points.iter().fold(
        (
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        ),
        |b, p| (b.0.min(p.0), b.1.min(p.1), b.2.max(p.0), b.3.max(p.1)),
    )
}

/// An even subsample (every k-th point) of at most `n` points.
fn subsample(points: &[(f64, f64)], n: usize) -> Vec<(f64, f64)> {
    let stride = points.len().div_ceil(n).max(1);
    points.iter().step_by(stride).copied().collect()
}

/// Of `points` moved by `t`: how many land on a known cell of `to` or within `tol` metres
/// of its walls, and how many are within `tol` of its walls.
fn agreement(points: &[(f64, f64)], t: &Se2, to: &Prepared, tol: f64) -> (u64, u64) {
    let a = to.to_cell.after(&t.affine());
    let (h, w) = (to.frame.height as i64, to.frame.width as i64);
    let tol2 = tol * tol;
    let parts: Vec<(u64, u64)> = points
        .par_chunks(CHUNK)
        .map(|chunk| {
            let (mut landed, mut near) = (0u64, 0u64);
            for &(x, y) in chunk {
                let (rf, cf) = a.apply(x, y);
                let (r, c) = (floor_i64(rf), floor_i64(cf));
                let inside = r >= 0 && c >= 0 && r < h && c < w;
                let (rq, cq) = (r.clamp(0, h - 1) as usize, c.clamp(0, w - 1) as usize);
                let close = match to.columns.query(rq, cq) {
                    Some((n, _)) => {
                        let n = n as usize;
                        let wd = to.frame.width;
                        let (gx, gy) = to.to_world.apply((n / wd) as f64, (n % wd) as f64);
                        // the point itself, back in world coordinates
                        let (px, py) = t.apply(x, y);
                        (px - gx).powi(2) + (py - gy).powi(2) <= tol2
                    }
                    None => false,
                };
                let known = inside && !to.unknown[rq * to.frame.width + cq];
                landed += (known || close) as u64;
                near += close as u64;
            }
            (landed, near)
        })
        .collect();
    parts
        .into_iter()
        .fold((0, 0), |a, b| (a.0 + b.0, a.1 + b.1))
}

/// The coarse rasters and FFT plans of one pair.
struct Coarse {
    res: f64,
    nr: usize,
    nc: usize,
    /// The fixed raster's lower-left corner (world) and size.
    x0: f64,
    y0: f64,
    fh: usize,
    fw: usize,
    /// The fixed raster's spectrum, transposed (column-major).
    spectrum: Vec<Complex<f64>>,
    row_fwd: Arc<dyn Fft<f64>>,
    col_fwd: Arc<dyn Fft<f64>>,
    row_inv: Arc<dyn Fft<f64>>,
    col_inv: Arc<dyn Fft<f64>>,
}

/// In place: `buf` (`nr x nc` row-major) -> its 2-D transform, transposed (`nc x nr`).
fn fft2(
    buf: &mut Vec<Complex<f64>>,
    nr: usize,
    nc: usize,
    rows: &dyn Fft<f64>,
    cols: &dyn Fft<f64>,
) {
    rows.process(buf);
    let mut t = vec![Complex::new(0.0, 0.0); nr * nc];
    transpose::transpose(buf, &mut t, nc, nr);
    cols.process(&mut t);
    *buf = t;
}

/// In place: the inverse of [`fft2`] (`nc x nr` transposed spectrum -> `nr x nc`), unscaled.
fn ifft2(
    buf: &mut Vec<Complex<f64>>,
    nr: usize,
    nc: usize,
    rows: &dyn Fft<f64>,
    cols: &dyn Fft<f64>,
) {
    cols.process(buf);
    let mut t = vec![Complex::new(0.0, 0.0); nr * nc];
    transpose::transpose(buf, &mut t, nr, nc);
    rows.process(&mut t);
    *buf = t;
}

impl Coarse {
    fn new(moving: &Prepared, fixed: &Prepared) -> Coarse {
        Coarse::with_cells(moving, fixed, COARSE_CELLS)
    }

    /// The rasters at most `cells` cells a side (and at least two cells of the coarser map).
    fn with_cells(moving: &Prepared, fixed: &Prepared, cells: f64) -> Coarse {
        let fb = bounds(&fixed.points);
        let mb = bounds(&moving.points);
        let diag = (mb.2 - mb.0).hypot(mb.3 - mb.1);
        let extent = (fb.2 - fb.0).max(fb.3 - fb.1).max(diag);
        let floor = 2.0 * moving.frame.resolution.max(fixed.frame.resolution);
        let res = (extent / cells).max(floor);
        let fh = ((fb.3 - fb.1) / res).floor() as usize + 1;
        let fw = ((fb.2 - fb.0) / res).floor() as usize + 1;
        let md = (diag / res).floor() as usize + 2;
        let nr = (fh + md).next_power_of_two();
        let nc = (fw + md).next_power_of_two();
        let mut planner = FftPlanner::new();
        let row_fwd = planner.plan_fft_forward(nc);
        let col_fwd = planner.plan_fft_forward(nr);
        let row_inv = planner.plan_fft_inverse(nc);
        let col_inv = planner.plan_fft_inverse(nr);
        // fixed: 2 on a wall cell, 1 beside one
        let mut wall = vec![false; fh * fw];
        for &(x, y) in &fixed.points {
            let r = ((y - fb.1) / res) as usize;
            let c = ((x - fb.0) / res) as usize;
            wall[r.min(fh - 1) * fw + c.min(fw - 1)] = true;
        }
        let mut buf = vec![Complex::new(0.0, 0.0); nr * nc];
        for r in 0..fh {
            for c in 0..fw {
                let v = if wall[r * fw + c] {
                    2.0
                } else {
                    let mut any = false;
                    for rr in r.saturating_sub(1)..=(r + 1).min(fh - 1) {
                        for cc in c.saturating_sub(1)..=(c + 1).min(fw - 1) {
                            any |= wall[rr * fw + cc];
                        }
                    }
                    if any {
                        1.0
                    } else {
                        0.0
                    }
                };
                buf[r * nc + c] = Complex::new(v, 0.0);
            }
        }
        fft2(&mut buf, nr, nc, &*row_fwd, &*col_fwd);
        Coarse {
            res,
            nr,
            nc,
            x0: fb.0,
            y0: fb.1,
            fh,
            fw,
            spectrum: buf,
            row_fwd,
            col_fwd,
            row_inv,
            col_inv,
        }
    }

    /// The moving points turned by `theta`, rasterised (1 per wall cell) into `buf` (real
    /// part when `imag` is false, else imaginary part); their raster's lower-left corner
    /// and the number of wall cells.
    fn raster(
        &self,
        points: &[(f64, f64)],
        theta: f64,
        buf: &mut [Complex<f64>],
        imag: bool,
    ) -> (f64, f64, usize) {
        let (s, c) = theta.sin_cos();
        let turned: Vec<(f64, f64)> = points
            .iter()
            .map(|&(x, y)| (c * x - s * y, s * x + c * y))
            .collect();
        let b = bounds(&turned);
        let mut count = 0;
        for (x, y) in turned {
            let r = ((y - b.1) / self.res) as usize;
            let cc = ((x - b.0) / self.res) as usize;
            let (r, cc) = (r.min(self.nr - 1), cc.min(self.nc - 1));
            let v = &mut buf[r * self.nc + cc];
            let slot = if imag { &mut v.im } else { &mut v.re };
            if *slot == 0.0 {
                *slot = 1.0;
                count += 1;
            }
        }
        (b.0, b.1, count)
    }

    /// The best [`TRANSLATION_PEAKS`] shifts of the moving walls turned by each of two
    /// rotations (one FFT pair for both): `(score, theta, transform)`, score = the
    /// correlation over twice the moving wall cells.
    fn shifts(&self, points: &[(f64, f64)], thetas: &[f64]) -> Vec<(f64, Se2)> {
        let (nr, nc) = (self.nr, self.nc);
        let mut buf = vec![Complex::new(0.0, 0.0); nr * nc];
        let corners: Vec<(f64, f64, usize)> = thetas
            .iter()
            .enumerate()
            .map(|(k, &t)| self.raster(points, t, &mut buf, k == 1))
            .collect();
        fft2(&mut buf, nr, nc, &*self.row_fwd, &*self.col_fwd);
        for (b, f) in buf.iter_mut().zip(&self.spectrum) {
            *b = b.conj() * f;
        }
        ifft2(&mut buf, nr, nc, &*self.row_inv, &*self.col_inv);
        let scale = 1.0 / (nr * nc) as f64;
        let mut out = Vec::new();
        for (k, (&theta, &(mx0, my0, count))) in thetas.iter().zip(&corners).enumerate() {
            // real part: the first rotation's correlation, minus the imaginary: the second's
            let value = |i: usize| {
                let v = buf[i];
                scale * if k == 0 { v.re } else { -v.im }
            };
            let norm = 2.0 * count.max(1) as f64;
            for (score, i) in peaks(&value, nr, nc, TRANSLATION_PEAKS) {
                let (r, c) = (i / nc, i % nc);
                // shift s: moving raster cell q lands on fixed raster cell q + s
                let sr = if r < self.fh {
                    r as f64
                } else {
                    r as f64 - nr as f64
                };
                let sc = if c < self.fw {
                    c as f64
                } else {
                    c as f64 - nc as f64
                };
                let t = Se2 {
                    theta: wrap(theta),
                    tx: self.x0 - mx0 + sc * self.res,
                    ty: self.y0 - my0 + sr * self.res,
                };
                out.push((score / norm, t));
            }
        }
        out
    }
}

/// The `n` highest local maxima (3 x 3, circular) of `value` over an `nr x nc` grid, at
/// least 3 cells apart: `(value, index)`, highest first (ties: lowest index).
fn peaks(value: &dyn Fn(usize) -> f64, nr: usize, nc: usize, n: usize) -> Vec<(f64, usize)> {
    let mut maxima: Vec<(f64, usize)> = Vec::new();
    for r in 0..nr {
        for c in 0..nc {
            let i = r * nc + c;
            let v = value(i);
            if v <= 0.5 {
                continue;
            }
            let mut top = true;
            'n: for dr in [nr - 1, 0, 1] {
                for dc in [nc - 1, 0, 1] {
                    if dr == 0 && dc == 0 {
                        continue;
                    }
                    let j = ((r + dr) % nr) * nc + (c + dc) % nc;
                    let u = value(j);
                    if u > v || (u == v && j < i) {
                        top = false;
                        break 'n;
                    }
                }
            }
            if top {
                maxima.push((v, i));
            }
        }
    }
    maxima.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    let mut out: Vec<(f64, usize)> = Vec::new();
    for (v, i) in maxima {
        let (r, c) = ((i / nc) as isize, (i % nc) as isize);
        let far = out.iter().all(|&(_, j)| {
            let (rj, cj) = ((j / nc) as isize, (j % nc) as isize);
            let dr = (r - rj).rem_euclid(nr as isize);
            let dc = (c - cj).rem_euclid(nc as isize);
            dr.min(nr as isize - dr).max(dc.min(nc as isize - dc)) >= 3
        });
        if far {
            out.push((v, i));
            if out.len() == n {
                break;
            }
        }
    }
    out
}

/// How far apart two transforms put the moving points: the distance between the images of
/// the points' centroid plus the turn times the points' RMS radius.
fn apart(a: &Se2, b: &Se2, centroid: (f64, f64), radius: f64) -> f64 {
    let (p, q) = (
        a.apply(centroid.0, centroid.1),
        b.apply(centroid.0, centroid.1),
    );
    (p.0 - q.0).hypot(p.1 - q.1) + wrap(a.theta - b.theta).abs() * radius
}

/// Register `moving` onto `fixed` (both prepared): see the module documentation. The
/// first search (wall directions, steps 1-5) decides when it places the map; when it
/// refuses, the wide search ([`wide`]: both maps on the coarser one's grid, every
/// [`SWEEP_DEG`] degrees, runner-ups refined before they count) is tried, and its answer
/// is kept only when it places the map; else the first search's refusal stands.
pub fn register_prepared(
    moving: &Prepared,
    fixed: &Prepared,
    params: &RegisterParams,
) -> Result<Registration, Error> {
    let first = search(moving, fixed, params)?;
    if first.ok || first.candidates == 0 {
        return Ok(first);
    }
    match wide(moving, fixed, params, first.tolerance)? {
        Some(r) if r.ok => Ok(r),
        _ => Ok(first),
    }
}

/// Steps 1-5 of the module documentation on the maps as given.
fn search(
    moving: &Prepared,
    fixed: &Prepared,
    params: &RegisterParams,
) -> Result<Registration, Error> {
    check_params(params)?;
    let tol = params
        .tolerance
        .unwrap_or((2.0 * moving.frame.resolution.max(fixed.frame.resolution)).max(0.2));
    for (p, what) in [(moving, "moving"), (fixed, "fixed")] {
        if p.points.len() < MIN_POINTS {
            return Ok(Registration::refused(
                format!(
                    "the {what} map has {} occupied cells (at least {MIN_POINTS} needed)",
                    p.points.len()
                ),
                tol,
            ));
        }
        if p.histogram.iter().sum::<f64>() <= 1e-9 {
            return Ok(Registration::refused(
                format!("the {what} map has no straight wall"),
                tol,
            ));
        }
    }
    let thetas = rotations(&moving.histogram, &fixed.histogram);
    let coarse = Coarse::new(moving, fixed);
    // coarse candidates: two rotations per FFT pair
    let pairs: Vec<&[f64]> = thetas.chunks(2).collect();
    let found: Vec<Vec<(f64, Se2)>> = pairs
        .par_iter()
        .map(|ts| coarse.shifts(&moving.points, ts))
        .collect();
    let mut candidates: Vec<(f64, Se2)> = found.into_iter().flatten().collect();
    // best first; ties keep the order found (stable sort)
    candidates.sort_by(|a, b| b.0.total_cmp(&a.0));
    candidates.truncate(REFINED);
    let target = Target::new(fixed.frame, &fixed.columns, &fixed.mask, &fixed.cells)?;
    let sample = subsample(&moving.points, SCORE_POINTS);
    let back = subsample(&fixed.points, SCORE_POINTS);
    let refined: Vec<(f64, Se2)> = candidates
        .par_iter()
        .map(|&(_, start)| {
            let t = icp(&sample, &target, start, params.trim, SHORT_ITERATIONS)
                .map_or(start, |r| r.transform);
            (candidate_score(&sample, &back, &t, moving, fixed, tol), t)
        })
        .collect();
    let Some(best) =
        (0..refined.len()).reduce(|a, b| if refined[b].0 > refined[a].0 { b } else { a })
    else {
        return Ok(Registration::refused(
            "no candidate alignment was found".to_string(),
            tol,
        ));
    };
    let (score, start) = refined[best];
    let final_icp = icp(
        &moving.points,
        &target,
        start,
        params.trim,
        params.max_iterations,
    );
    let transform = final_icp.map_or(start, |r| r.transform);
    // the best distinct runner-up
    let (centroid, radius) = spread(&moving.points);
    let distinct = (5.0 * tol).max(1.0);
    let runner = refined
        .iter()
        .filter(|(_, t)| apart(t, &transform, centroid, radius) > distinct)
        .fold(None, |acc: Option<(f64, Se2)>, &(s, t)| match acc {
            Some((a, _)) if a >= s => acc,
            _ => Some((s, t)),
        });
    let margin = match runner {
        Some((s, _)) if score > 0.0 => (1.0 - s / score).clamp(0.0, 1.0),
        Some(_) => 0.0,
        None => 1.0,
    };
    Ok(finish(
        moving,
        fixed,
        params,
        tol,
        Found {
            transform,
            score,
            runner,
            margin,
            icp: final_icp,
            rotations: thetas.len(),
            candidates: refined.len(),
        },
    ))
}

/// What a search found, before its figures: the motion, its score, the best distinct
/// runner-up, the margin, the final ICP, rotations tried and candidates refined.
struct Found {
    transform: Se2,
    score: f64,
    runner: Option<(f64, Se2)>,
    margin: f64,
    icp: Option<IcpResult>,
    rotations: usize,
    candidates: usize,
}

/// The centroid of points and their RMS distance to it.
fn spread(points: &[(f64, f64)]) -> ((f64, f64), f64) {
    let m = points.len() as f64;
    let centroid = points
        .iter()
        .fold((0.0, 0.0), |a, p| (a.0 + p.0 / m, a.1 + p.1 / m));
    let radius = (points
        .iter()
        .map(|p| (p.0 - centroid.0).powi(2) + (p.1 - centroid.1).powi(2))
        .sum::<f64>()
        / m)
        .sqrt();
    (centroid, radius)
}

/// A candidate's score (module documentation, step 4): the share of the moving `sample`
/// within `tol` of a fixed wall at `t`, times the consistency of the fixed sample `back`
/// where it lands on the moving map.
fn candidate_score(
    sample: &[(f64, f64)],
    back: &[(f64, f64)],
    t: &Se2,
    moving: &Prepared,
    fixed: &Prepared,
    tol: f64,
) -> f64 {
    let (_, near) = agreement(sample, t, fixed, tol);
    // the fixed walls that land on the moving map's known cells must agree too: a
    // turned copy that fits some walls puts others in the moving map's free space
    let (landed, agree) = agreement(back, &t.inverse(), moving, tol);
    let consistent = if landed == 0 {
        0.0
    } else {
        agree as f64 / landed as f64
    };
    near as f64 / sample.len() as f64 * consistent
}

/// The figures of a found motion, both ways, and the refusal test (module documentation,
/// step 5).
fn finish(
    moving: &Prepared,
    fixed: &Prepared,
    params: &RegisterParams,
    tol: f64,
    found: Found,
) -> Registration {
    let Found {
        transform,
        score,
        runner,
        margin,
        icp: final_icp,
        rotations,
        candidates,
    } = found;
    // final figures, both ways
    let ms = subsample(&moving.points, FIGURE_POINTS);
    let fs = subsample(&fixed.points, FIGURE_POINTS);
    let (ml, mn) = agreement(&ms, &transform, fixed, tol);
    let (fl, fnear) = agreement(&fs, &transform.inverse(), moving, tol);
    let ratio = |a: u64, b: u64| if b == 0 { 0.0 } else { a as f64 / b as f64 };
    let inliers_moving = ratio(mn, ml);
    let inliers_fixed = ratio(fnear, fl);
    let overlap_moving = ratio(ml, ms.len() as u64);
    let overlap_fixed = ratio(fl, fs.len() as u64);
    let inliers = inliers_moving.min(inliers_fixed);
    let overlap = overlap_moving.max(overlap_fixed);
    let mut reasons = Vec::new();
    if overlap < params.min_overlap {
        reasons.push(format!(
            "the maps barely overlap (overlap {overlap:.2} < {})",
            params.min_overlap
        ));
    }
    if inliers < params.min_inliers {
        reasons.push(format!(
            "the walls disagree where the maps overlap (inliers {inliers:.2} < {}; moving \
             {inliers_moving:.2}, fixed {inliers_fixed:.2})",
            params.min_inliers
        ));
    }
    if margin < params.min_margin {
        let (s, t) = runner.unwrap_or((f64::NAN, Se2::IDENTITY));
        reasons.push(format!(
            "ambiguous: another alignment ({:.1} deg, {:.2} m, {:.2} m) fits nearly as well \
             (score {s:.3} against {score:.3}; margin {margin:.3} < {})",
            t.theta.to_degrees(),
            t.tx,
            t.ty,
            params.min_margin
        ));
    }
    let ok = reasons.is_empty();
    let confidence = if ok {
        (inliers * (margin / MARGIN_FULL).min(1.0)).clamp(0.0, 1.0)
    } else {
        0.0
    };
    Registration {
        ok,
        reason: reasons.join("; "),
        transform,
        inliers,
        inliers_moving,
        inliers_fixed,
        overlap,
        overlap_moving,
        overlap_fixed,
        score,
        runner_up_score: runner.map_or(f64::NAN, |r| r.0),
        runner_up: runner.map(|r| r.1),
        margin,
        confidence,
        icp_rms: final_icp.map_or(f64::NAN, |r| r.rms),
        icp_iterations: final_icp.map_or(0, |r| r.iterations),
        rotations,
        candidates,
        tolerance: tol,
    }
}

/// A map drawn again on a coarser grid of the same origin and yaw (`res` metres a cell): a
/// coarse cell is occupied when the centre of an occupied fine cell falls in it, known when
/// the centre of a known fine cell does (free cells are 255, occupied 0).
struct Pooled {
    values: Vec<u8>,
    unknown: Vec<bool>,
    frame: Frame,
}

impl Pooled {
    fn new(p: &Prepared, res: f64) -> Result<Pooled, Error> {
        let f = p.frame;
        let k = f.resolution / res;
        let ch = ((f.height as f64 * k).ceil() as usize).max(1);
        let cw = ((f.width as f64 * k).ceil() as usize).max(1);
        let mut values = filled(ch * cw, 255u8)?;
        let mut unknown = filled(ch * cw, true)?;
        let cols: Vec<usize> = (0..f.width)
            .map(|c| (((c as f64 + 0.5) * k).floor() as usize).min(cw - 1))
            .collect();
        for r in 0..f.height {
            // rows count down from the top; the origin is the bottom-left corner
            let up = (((f.height - 1 - r) as f64 + 0.5) * k).floor() as usize;
            let cr = ch - 1 - up.min(ch - 1);
            for (c, &cc) in cols.iter().enumerate() {
                let i = r * f.width + c;
                let j = cr * cw + cc;
                if !p.unknown[i] {
                    unknown[j] = false;
                }
                if p.mask[i] {
                    values[j] = 0;
                }
            }
        }
        Ok(Pooled {
            values,
            unknown,
            frame: Frame {
                resolution: res,
                height: ch,
                width: cw,
                origin: f.origin,
            },
        })
    }

    fn placed(&self) -> Result<Placed<'_>, Error> {
        let grid = Grid::new(
            &self.values,
            &self.unknown,
            self.frame.height,
            self.frame.width,
        )
        .map_err(|e| Error::Invalid(e.to_string()))?;
        Ok(Placed {
            grid,
            frame: self.frame,
        })
    }
}

/// Whether two motions put the moving map in one place: they turn it by less than
/// [`SAME_PLACE_DEG`] apart and move its centroid less than `distinct` metres apart (two
/// fits of one place, a few degrees apart when the map is bent, are one hypothesis; a
/// symmetric place's alternatives are turned by 90 or 180 degrees, or shifted by a room).
fn same_place(a: &Se2, b: &Se2, centroid: (f64, f64), distinct: f64) -> bool {
    let (p, q) = (
        a.apply(centroid.0, centroid.1),
        b.apply(centroid.0, centroid.1),
    );
    (p.0 - q.0).hypot(p.1 - q.1) <= distinct
        && wrap(a.theta - b.theta).abs() < SAME_PLACE_DEG.to_radians()
}

/// The wide search, for maps the first search refused: both maps on the coarser map's
/// grid ([`Pooled`]: a finer map's walls thinned to one cell of the coarser grid, so that
/// wall directions, rasters and counts are alike), rotations every [`SWEEP_DEG`] degrees
/// besides the histogram peaks (the peaks of a small overlap drown in the walls outside
/// it), the [`WIDE_REFINED`] best candidates by coarse score that are not one place
/// refined by the short ICP and scored as in step 4, the best by the full ICP; then the
/// runner-ups in order of score, each refined by the full ICP, until one lands in another
/// place ([`same_place`], at most [`RUNNER_TRIES`]): the margin is to its score, both
/// scores taken after the full ICP. The figures and the refusal test are the first
/// search's, on the common grid. None when a map has too few walls on that grid.
fn wide(
    moving: &Prepared,
    fixed: &Prepared,
    params: &RegisterParams,
    tol: f64,
) -> Result<Option<Registration>, Error> {
    let res = moving.frame.resolution.max(fixed.frame.resolution);
    let coarser = |p: &Prepared| p.frame.resolution < res * (1.0 - 1e-9);
    let pooled_m = if coarser(moving) {
        Some(Pooled::new(moving, res)?)
    } else {
        None
    };
    let pooled_f = if coarser(fixed) {
        Some(Pooled::new(fixed, res)?)
    } else {
        None
    };
    let placed_m = pooled_m.as_ref().map(Pooled::placed).transpose()?;
    let placed_f = pooled_f.as_ref().map(Pooled::placed).transpose()?;
    let prep_m = placed_m
        .as_ref()
        .map(|p| prepare(p, params.occupied_threshold, "moving"))
        .transpose()?;
    let prep_f = placed_f
        .as_ref()
        .map(|p| prepare(p, params.occupied_threshold, "fixed"))
        .transpose()?;
    let m = prep_m.as_ref().unwrap_or(moving);
    let f = prep_f.as_ref().unwrap_or(fixed);
    if m.points.len() < MIN_POINTS || f.points.len() < MIN_POINTS {
        return Ok(None);
    }
    let mut thetas =
        if m.histogram.iter().sum::<f64>() > 1e-9 && f.histogram.iter().sum::<f64>() > 1e-9 {
            rotations(&m.histogram, &f.histogram)
        } else {
            Vec::new()
        };
    let steps = (360.0 / SWEEP_DEG).round() as usize;
    let half = (0.5 * SWEEP_DEG).to_radians();
    for k in 0..steps {
        let a = (k as f64 * SWEEP_DEG).to_radians();
        let close = thetas.iter().any(|&b| {
            let d = (a - b).rem_euclid(std::f64::consts::TAU);
            d.min(std::f64::consts::TAU - d) < half
        });
        if !close {
            thetas.push(a);
        }
    }
    let coarse = Coarse::with_cells(m, f, WIDE_COARSE_CELLS);
    let pairs: Vec<&[f64]> = thetas.chunks(2).collect();
    let found: Vec<Vec<(f64, Se2)>> = pairs
        .par_iter()
        .map(|ts| coarse.shifts(&m.points, ts))
        .collect();
    let mut all: Vec<(f64, Se2)> = found.into_iter().flatten().collect();
    all.sort_by(|a, b| b.0.total_cmp(&a.0));
    let (centroid, _) = spread(&m.points);
    let distinct = (5.0 * tol).max(1.0);
    let mut candidates: Vec<(f64, Se2)> = Vec::new();
    for c in all {
        if !candidates
            .iter()
            .any(|k| same_place(&k.1, &c.1, centroid, distinct))
        {
            candidates.push(c);
            if candidates.len() == WIDE_REFINED {
                break;
            }
        }
    }
    let target = Target::new(f.frame, &f.columns, &f.mask, &f.cells)?;
    let trim = WIDE_TRIM.max(params.trim);
    let sample = subsample(&m.points, SCORE_POINTS);
    let back = subsample(&f.points, SCORE_POINTS);
    let refined: Vec<(f64, Se2)> = candidates
        .par_iter()
        .map(|&(_, start)| {
            let t =
                icp(&sample, &target, start, trim, SHORT_ITERATIONS).map_or(start, |r| r.transform);
            (candidate_score(&sample, &back, &t, m, f, tol), t)
        })
        .collect();
    let mut order: Vec<usize> = (0..refined.len()).collect();
    // best first; ties keep the order found (stable sort)
    order.sort_by(|&a, &b| refined[b].0.total_cmp(&refined[a].0));
    let Some(&best) = order.first() else {
        return Ok(None);
    };
    let full = |start: Se2| {
        let r = icp(&m.points, &target, start, trim, params.max_iterations);
        (r.map_or(start, |r| r.transform), r)
    };
    let (transform, final_icp) = full(refined[best].1);
    let score = candidate_score(&sample, &back, &transform, m, f, tol);
    let mut runner = None;
    let mut tries = 0;
    for &k in &order[1..] {
        if tries == RUNNER_TRIES {
            break;
        }
        if same_place(&refined[k].1, &transform, centroid, distinct) {
            continue;
        }
        tries += 1;
        let (t, _) = full(refined[k].1);
        if !same_place(&t, &transform, centroid, distinct) {
            runner = Some((candidate_score(&sample, &back, &t, m, f, tol), t));
            break;
        }
    }
    let margin = match runner {
        Some((s, _)) if score > 0.0 => (1.0 - s / score).clamp(0.0, 1.0),
        Some(_) => 0.0,
        None => 1.0,
    };
    let strict = RegisterParams {
        min_margin: params.min_margin.max(WIDE_MIN_MARGIN),
        ..*params
    };
    Ok(Some(finish(
        m,
        f,
        &strict,
        tol,
        Found {
            transform,
            score,
            runner,
            margin,
            icp: final_icp,
            rotations: thetas.len(),
            candidates: refined.len(),
        },
    )))
}

/// Register `moving` onto `fixed`: [`prepare`] both, then [`register_prepared`].
pub fn register(
    moving: &Placed,
    fixed: &Placed,
    params: &RegisterParams,
) -> Result<Registration, Error> {
    check_params(params)?;
    let m = prepare(moving, params.occupied_threshold, "moving")?;
    let f = prepare(fixed, params.occupied_threshold, "fixed")?;
    register_prepared(&m, &f, params)
}

/// One pair of [`register_many`]: `(fixed index, moving index)` and the registration.
pub type PairRegistration = ((usize, usize), Registration);

/// Every pair of `maps`: `maps[j]` registered onto `maps[i]` for `i < j`, in that order
/// (`(0, 1), (0, 2), ..., (1, 2), ...`). Each map is prepared once.
pub fn register_many(
    maps: &[Placed],
    params: &RegisterParams,
) -> Result<Vec<PairRegistration>, Error> {
    check_params(params)?;
    let prepared: Vec<Prepared> = maps
        .par_iter()
        .enumerate()
        .map(|(k, m)| prepare(m, params.occupied_threshold, &format!("map {k}")))
        .collect::<Result<_, _>>()?;
    let pairs: Vec<(usize, usize)> = (0..maps.len())
        .flat_map(|i| (i + 1..maps.len()).map(move |j| (i, j)))
        .collect();
    pairs
        .par_iter()
        .map(|&(i, j)| {
            Ok((
                (i, j),
                register_prepared(&prepared[j], &prepared[i], params)?,
            ))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::Grid;

    /// A building's walls (cells of a 0.05 m grid, rows down): an outline with an
    /// asymmetric set of inner walls, doors and a pillar.
    fn building(r: usize, c: usize) -> bool {
        let outer = r == 10 || r == 110 || c == 10 || c == 150;
        let inner = (c == 70 && !(40..50).contains(&r)) || (r == 60 && c < 70 && c > 30);
        let pillar = (85..90).contains(&r) && (110..115).contains(&c);
        let nook = c == 120 && (10..40).contains(&r);
        ((10..=110).contains(&r) && (10..=150).contains(&c)) && (outer || inner || pillar || nook)
    }

    /// `h x w` values and unknown mask: walls where `wall` says, free elsewhere.
    fn raster(h: usize, w: usize, wall: impl Fn(usize, usize) -> bool) -> (Vec<u8>, Vec<bool>) {
        let mut v = vec![254u8; h * w];
        for r in 0..h {
            for c in 0..w {
                if wall(r, c) {
                    v[r * w + c] = 0;
                }
            }
        }
        (v, vec![false; h * w])
    }

    fn frame(h: usize, w: usize, res: f64, origin: Se2) -> Frame {
        Frame {
            resolution: res,
            height: h,
            width: w,
            origin,
        }
    }

    /// The building's walls (those left of `keep` of its width), in a world moved by
    /// `origin^-1`, drawn on a grid of resolution `res` covering them: the values, unknown
    /// mask and frame. `origin` takes this map's world onto the building's.
    fn resampled(res: f64, origin: Se2, keep: f64) -> (Vec<u8>, Vec<bool>, Frame) {
        let inv = origin.inverse();
        let mut pts = Vec::new();
        for r in 0..120 {
            for c in 0..160 {
                if building(r, c) && (c as f64) < 160.0 * keep {
                    let (x, y) = ((c as f64 + 0.5) * 0.05, (120.0 - r as f64 - 0.5) * 0.05);
                    pts.push(inv.apply(x, y));
                }
            }
        }
        let b = bounds(&pts);
        let (ox, oy) = (b.0 - 2.0 * res, b.1 - 2.0 * res);
        let h = ((b.3 - oy) / res).ceil() as usize + 2;
        let w = ((b.2 - ox) / res).ceil() as usize + 2;
        let (mut v, u) = raster(h, w, |_, _| false);
        for (x, y) in pts {
            let (rr, cc) = (h as f64 - (y - oy) / res, (x - ox) / res);
            v[rr as usize * w + cc as usize] = 0;
        }
        let origin = Se2 {
            theta: 0.0,
            tx: ox,
            ty: oy,
        };
        (v, u, frame(h, w, res, origin))
    }

    fn run(theta_deg: f64, res: f64, keep: f64) {
        let (fv, fu) = raster(120, 160, building);
        let fixed = Placed {
            grid: Grid::new(&fv, &fu, 120, 160).unwrap(),
            frame: frame(120, 160, 0.05, Se2::IDENTITY),
        };
        let origin = Se2 {
            theta: theta_deg.to_radians(),
            tx: 3.0,
            ty: -2.0,
        };
        let (mv, mu, mf) = resampled(res, origin, keep);
        let moving = Placed {
            grid: Grid::new(&mv, &mu, mf.height, mf.width).unwrap(),
            frame: mf,
        };
        let r = register(&moving, &fixed, &RegisterParams::default()).unwrap();
        assert!(r.ok, "{theta_deg}: {r:?}");
        let t = r.transform;
        assert!(
            wrap(t.theta - origin.theta).abs() < 0.5f64.to_radians(),
            "{theta_deg}: {t:?}"
        );
        // every moving wall within one fixed cell of where it belongs
        for &(x, y) in &[(1.0, 1.0), (6.0, 4.0), (3.0, 5.0)] {
            let (p, q) = (t.apply(x, y), origin.apply(x, y));
            assert!((p.0 - q.0).hypot(p.1 - q.1) < 0.05, "{theta_deg}: {t:?}");
        }
        // the outline is a rectangle: the half-turn fits most walls too, hence a modest margin
        assert!(r.margin > 0.1 && r.confidence > 0.2, "{r:?}");
    }

    #[test]
    fn any_rotation_other_resolution_and_crop() {
        for theta in [37.0, 123.0, 250.0] {
            run(theta, 0.05, 1.0);
        }
        run(123.0, 0.04, 0.6);
        run(250.0, 0.07, 0.6);
    }

    #[test]
    fn a_symmetric_map_is_ambiguous() {
        // a plain rectangle: 180 degrees fits as well as 0
        let wall = |r: usize, c: usize| {
            ((r == 10 || r == 70) && (10..=130).contains(&c))
                || ((c == 10 || c == 130) && (10..=70).contains(&r))
        };
        let (v, u) = raster(80, 140, wall);
        let p = Placed {
            grid: Grid::new(&v, &u, 80, 140).unwrap(),
            frame: frame(80, 140, 0.05, Se2::IDENTITY),
        };
        let r = register(&p, &p, &RegisterParams::default()).unwrap();
        assert!(r.margin < 0.1, "{r:?}");
        assert!(!r.ok && r.reason.contains("ambiguous"), "{r:?}");
        assert_eq!(r.confidence, 0.0);
    }

    #[test]
    fn empty_and_wall_less_maps_are_refused() {
        let (fv, fu) = raster(120, 160, building);
        let fixed = Placed {
            grid: Grid::new(&fv, &fu, 120, 160).unwrap(),
            frame: frame(120, 160, 0.05, Se2::IDENTITY),
        };
        let (ev, eu) = raster(50, 50, |_, _| false);
        let empty = Placed {
            grid: Grid::new(&ev, &eu, 50, 50).unwrap(),
            frame: frame(50, 50, 0.05, Se2::IDENTITY),
        };
        let r = register(&empty, &fixed, &RegisterParams::default()).unwrap();
        assert!(!r.ok && r.reason.contains("occupied cells"), "{r:?}");
        // isolated dots, no wall: no direction
        let (dv, du) = raster(50, 50, |r, c| r % 10 == 0 && c % 10 == 0);
        let dots = Placed {
            grid: Grid::new(&dv, &du, 50, 50).unwrap(),
            frame: frame(50, 50, 0.05, Se2::IDENTITY),
        };
        let r = register(&fixed, &dots, &RegisterParams::default()).unwrap();
        assert!(!r.ok, "{r:?}");
        assert!(r.reason.contains("occupied cells") || r.reason.contains("straight wall"));
        // a bad frame is an error, not a refusal
        let bad = Placed {
            frame: frame(50, 50, 0.0, Se2::IDENTITY),
            ..empty
        };
        assert!(register(&bad, &fixed, &RegisterParams::default()).is_err());
    }

    #[test]
    fn pooling_keeps_walls_in_place_and_unknown_where_nothing_was_seen() {
        // a 0.02 m map: a wall row, a wall column, an unknown band on the right
        let (h, w) = (50, 60);
        let mut v = vec![254u8; h * w];
        let mut u = vec![false; h * w];
        for c in 5..40 {
            v[20 * w + c] = 0;
        }
        for r in 5..45 {
            v[r * w + 10] = 0;
        }
        for r in 0..h {
            for c in 45..w {
                u[r * w + c] = true;
            }
        }
        let origin = Se2 {
            theta: 0.3,
            tx: 1.0,
            ty: -2.0,
        };
        let fine = Placed {
            grid: Grid::new(&v, &u, h, w).unwrap(),
            frame: frame(h, w, 0.02, origin),
        };
        let p = prepare(&fine, 0.5, "fine").unwrap();
        let pooled = Pooled::new(&p, 0.05).unwrap();
        assert_eq!((pooled.frame.height, pooled.frame.width), (20, 24));
        let coarse = prepare(&pooled.placed().unwrap(), 0.5, "coarse").unwrap();
        // every fine wall point lies in an occupied coarse cell, and every occupied coarse
        // cell holds one
        for &(x, y) in &p.points {
            let (r, c) = pooled.frame.cell_of(x, y).unwrap();
            assert_eq!(pooled.values[r * 24 + c], 0);
        }
        for &(x, y) in &coarse.points {
            assert!(p
                .points
                .iter()
                .any(|q| (q.0 - x).abs() <= 0.035 && (q.1 - y).abs() <= 0.035));
        }
        // the unknown band (fine columns 45.., from 0.9 m on: coarse columns 18..) is
        // unknown, the rest known
        for r in 0..20 {
            for c in 0..24 {
                let want = c >= 18;
                assert_eq!(pooled.unknown[r * 24 + c], want, "{r} {c}");
            }
        }
    }

    #[test]
    fn same_result_for_any_thread_count() {
        let (fv, fu) = raster(120, 160, building);
        let fixed = Placed {
            grid: Grid::new(&fv, &fu, 120, 160).unwrap(),
            frame: frame(120, 160, 0.05, Se2::IDENTITY),
        };
        let origin = Se2 {
            theta: 1.1,
            tx: 1.0,
            ty: 2.0,
        };
        let (mv, mu, mf) = resampled(0.05, origin, 0.8);
        let moving = Placed {
            grid: Grid::new(&mv, &mu, mf.height, mf.width).unwrap(),
            frame: mf,
        };
        let run = |t: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .unwrap()
                .install(|| register_many(&[fixed, moving, fixed], &RegisterParams::default()))
                .unwrap()
        };
        assert_eq!(run(1), run(3));
    }
}
