//! A map against a ground-truth map (SPEC section 7): align the estimate (frames from the
//! map files, refined by trimmed ICP), resample it onto the ground truth's grid, and count
//! what the figures need (matches within the tolerance, sums of distances, coverage).
//! Ratios and metres are formed by the caller from these.

use crate::edt::{edt, filled, Edt, EdtError};
use crate::grid::{Grid, BAND_ROWS};
use crate::icp::{icp, search, Target};
use crate::params::{Align, CompareParams};
use crate::se2::{Frame, Se2};
use rayon::prelude::*;
use std::fmt;

/// Bits of the per-cell flags [`Comparison::cells`] holds (one byte per ground-truth cell).
pub mod flag {
    /// The aligned estimate is occupied here (a cell of E).
    pub const ESTIMATE: u8 = 1;
    /// The ground truth is occupied here (a cell of G).
    pub const GROUND_TRUTH: u8 = 2;
    /// A cell of E within the tolerance of G (a matched estimate wall).
    pub const ESTIMATE_MATCHED: u8 = 4;
    /// A cell of G within the tolerance of E (a ground-truth wall the estimate has).
    pub const GROUND_TRUTH_MATCHED: u8 = 8;
    /// The aligned estimate knows this cell.
    pub const ESTIMATE_KNOWN: u8 = 16;
    /// The ground truth says this cell is free.
    pub const GROUND_TRUTH_FREE: u8 = 32;
}

/// One map and where its cells are.
#[derive(Clone, Copy, Debug)]
pub struct Placed<'a> {
    pub grid: Grid<'a>,
    pub frame: Frame,
}

/// Why two maps could not be compared.
#[derive(Debug, Clone, PartialEq)]
pub enum CompareError {
    /// A resolution that is not a positive finite number, a frame whose size differs from
    /// its grid's, or a parameter out of range.
    Invalid(String),
    /// The distance transform failed (size, memory).
    Edt(EdtError),
}

impl fmt::Display for CompareError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CompareError::Invalid(s) => f.write_str(s),
            CompareError::Edt(e) => e.fmt(f),
        }
    }
}

impl std::error::Error for CompareError {}

impl From<EdtError> for CompareError {
    fn from(e: EdtError) -> Self {
        CompareError::Edt(e)
    }
}

/// The counts and sums of one comparison. Distances are in cells of the ground truth's
/// grid; E and G are the occupied cells of the aligned estimate and of the ground truth on
/// that grid.
#[derive(Clone, Debug, PartialEq)]
pub struct Comparison {
    /// |E|, |G|.
    pub estimate_occupied: u64,
    pub ground_truth_occupied: u64,
    /// Cells of E within the tolerance of G; cells of G within the tolerance of E.
    pub estimate_matched: u64,
    pub ground_truth_matched: u64,
    /// |E n G|, |E u G|.
    pub intersection: u64,
    pub union: u64,
    /// Sum over E of d(e, G); sum over G of d(g, E) (each truncated at `max_distance`).
    pub sum_reverse: f64,
    pub sum_ne: f64,
    /// How many of those distances were truncated.
    pub truncated_reverse: u64,
    pub truncated_ne: u64,
    /// Free cells of the ground truth, and those the aligned estimate knows.
    pub ground_truth_free: u64,
    pub covered: u64,
    /// Occupied estimate cells whose centre, aligned, falls outside the ground truth's grid.
    pub outside: u64,
    /// The motion applied to the estimate's world frame.
    pub transform: Se2,
    /// The ICP's inlier RMS (metres), its iterations and kept pairs (NaN, 0, 0 without ICP).
    pub icp_rms: f64,
    pub icp_iterations: usize,
    pub icp_inliers: usize,
    /// Per ground-truth cell, the [`flag`] bits, when asked for.
    pub cells: Option<Vec<u8>>,
}

/// `occupied[v]`: a known cell of value `v` is occupied (`(255 - v) / 255 > threshold`).
fn occupied_table(threshold: f64) -> [bool; 256] {
    let mut t = [false; 256];
    for (v, o) in t.iter_mut().enumerate() {
        *o = (255 - v) as f64 / 255.0 > threshold;
    }
    t
}

fn check(p: &Placed, what: &str) -> Result<(), CompareError> {
    let f = &p.frame;
    let ok = f.resolution.is_finite()
        && f.resolution > 0.0
        && f.origin.theta.is_finite()
        && f.origin.tx.is_finite()
        && f.origin.ty.is_finite();
    if !ok {
        return Err(CompareError::Invalid(format!(
            "{what}: resolution must be positive and origin finite"
        )));
    }
    if f.height != p.grid.height || f.width != p.grid.width {
        return Err(CompareError::Invalid(format!(
            "{what}: frame size differs from the grid's"
        )));
    }
    Ok(())
}

fn check_params(p: &CompareParams) -> Result<(), CompareError> {
    let ok = p.tolerance.is_finite()
        && p.tolerance >= 0.0
        && p.occupied_threshold.is_finite()
        && (0.0..1.0).contains(&p.occupied_threshold)
        && p.max_distance.is_none_or(|m| m.is_finite() && m > 0.0)
        && (0.0..1.0).contains(&p.trim);
    if ok {
        Ok(())
    } else {
        Err(CompareError::Invalid(format!(
            "comparison parameters out of range: {p:?}"
        )))
    }
}

/// World centres of the occupied cells of `p`, in row-major order.
fn occupied_points(p: &Placed, occ: &[bool; 256]) -> Result<Vec<(f64, f64)>, CompareError> {
    let g = &p.grid;
    let n = g
        .values
        .iter()
        .zip(g.unknown)
        .filter(|(v, u)| !**u && occ[**v as usize])
        .count();
    let mut pts = Vec::new();
    pts.try_reserve_exact(n).map_err(|_| EdtError::Alloc {
        bytes: n.saturating_mul(16),
    })?;
    for r in 0..g.height {
        for (c, (v, u)) in g.value_row(r).iter().zip(g.unknown_row(r)).enumerate() {
            if !*u && occ[*v as usize] {
                pts.push(p.frame.centre(r, c));
            }
        }
    }
    Ok(pts)
}

/// The motion aligning the estimate, with the ICP's RMS, iterations and inliers.
fn align(
    points: &[(f64, f64)],
    gt: &Placed,
    gt_edt: &Edt,
    params: &CompareParams,
) -> (Se2, f64, usize, usize) {
    let target = Target::new(gt.frame, gt_edt);
    let start = match params.align {
        Align::Origin => return (Se2::IDENTITY, f64::NAN, 0, 0),
        Align::Icp => Se2::IDENTITY,
        Align::Search => search(points, &target, params.trim),
    };
    match icp(points, &target, start, params.trim, params.max_iterations) {
        Some(r) => (r.transform, r.rms, r.iterations, r.inliers),
        None => (start, f64::NAN, 0, 0),
    }
}

/// Affine map from a ground-truth cell `(row, col)` to the fractional cell position in the
/// estimate, under the estimate motion `t`: `est = a * (row, col) + b`.
fn gt_to_estimate(gt: &Frame, est: &Frame, t: &Se2) -> ([[f64; 2]; 2], [f64; 2]) {
    let (a, b) = gt.cell_to_world();
    let inv = t.inverse();
    let at = |r: f64, c: f64| {
        let w = (
            a[0][0] * r + a[0][1] * c + b[0],
            a[1][0] * r + a[1][1] * c + b[1],
        );
        let (x, y) = inv.apply(w.0, w.1);
        est.world_to_cell(x, y)
    };
    let o = at(0.0, 0.0);
    let dr = at(1.0, 0.0);
    let dc = at(0.0, 1.0);
    (
        [[dr.0 - o.0, dc.0 - o.0], [dr.1 - o.1, dc.1 - o.1]],
        [o.0, o.1],
    )
}

/// The aligned estimate on the ground truth's grid: [`flag::ESTIMATE`] and
/// [`flag::ESTIMATE_KNOWN`] bits. A ground-truth cell takes the state of the estimate cell
/// holding its centre (nearest neighbour); then every occupied estimate cell marks the
/// ground-truth cell holding its own centre, so that thin walls survive when the estimate's
/// grid is finer. Returns the flags and how many occupied estimate cells fell outside.
fn resample(
    est: &Placed,
    gt: &Frame,
    t: &Se2,
    occ: &[bool; 256],
    points: &[(f64, f64)],
) -> Result<(Vec<u8>, u64), CompareError> {
    let (h, w) = (gt.height, gt.width);
    let mut cells = filled(h * w, 0u8)?;
    let (a, b) = gt_to_estimate(gt, &est.frame, t);
    let (eh, ew) = (est.grid.height as f64, est.grid.width as f64);
    let eg = &est.grid;
    cells
        .par_chunks_mut(BAND_ROWS * w)
        .enumerate()
        .for_each(|(band, chunk)| {
            for (k, row) in chunk.chunks_mut(w).enumerate() {
                let r = (band * BAND_ROWS + k) as f64;
                for (c, cell) in row.iter_mut().enumerate() {
                    let c = c as f64;
                    let er = (a[0][0] * r + a[0][1] * c + b[0]).floor();
                    let ec = (a[1][0] * r + a[1][1] * c + b[1]).floor();
                    if er >= 0.0 && ec >= 0.0 && er < eh && ec < ew {
                        let i = er as usize * eg.width + ec as usize;
                        if !eg.unknown[i] {
                            *cell = flag::ESTIMATE_KNOWN
                                | if occ[eg.values[i] as usize] {
                                    flag::ESTIMATE
                                } else {
                                    0
                                };
                        }
                    }
                }
            }
        });
    let mut outside = 0u64;
    for &(x, y) in points {
        let (qx, qy) = t.apply(x, y);
        match gt.cell_of(qx, qy) {
            Some((r, c)) => cells[r * w + c] |= flag::ESTIMATE | flag::ESTIMATE_KNOWN,
            None => outside += 1,
        }
    }
    Ok((cells, outside))
}

/// Per-band partial counts, summed in band order (thread-count independent).
#[derive(Clone, Copy, Default)]
struct Partial {
    e: u64,
    g: u64,
    e_matched: u64,
    g_matched: u64,
    inter: u64,
    union: u64,
    sum_rev: f64,
    sum_ne: f64,
    trunc_rev: u64,
    trunc_ne: u64,
    free: u64,
    covered: u64,
}

/// A distance (cells) from a squared one, truncated; and whether it was.
#[inline]
fn distance(sq: u32, max: Option<f64>) -> (f64, bool) {
    let d = if sq == u32::MAX {
        f64::INFINITY
    } else {
        (sq as f64).sqrt()
    };
    match max {
        Some(m) if d > m => (m, true),
        _ => (d, false),
    }
}

/// Compare an estimate with a ground truth (SPEC section 7). `want_cells` keeps the per-cell
/// [`flag`] bits (for overlays).
pub fn compare(
    estimate: &Placed,
    ground_truth: &Placed,
    params: &CompareParams,
    want_cells: bool,
) -> Result<Comparison, CompareError> {
    check(estimate, "estimate")?;
    check(ground_truth, "ground truth")?;
    check_params(params)?;
    let occ = occupied_table(params.occupied_threshold);
    let gt = &ground_truth.grid;
    let (h, w) = (gt.height, gt.width);
    // G, and the ground truth's free cells
    let mut g_mask = filled(h * w, false)?;
    g_mask
        .par_chunks_mut(BAND_ROWS * w)
        .zip(gt.values.par_chunks(BAND_ROWS * w))
        .zip(gt.unknown.par_chunks(BAND_ROWS * w))
        .for_each(|((m, v), u)| {
            for ((m, v), u) in m.iter_mut().zip(v).zip(u) {
                *m = !*u && occ[*v as usize];
            }
        });
    let gt_edt = edt(&g_mask, h, w)?;
    let points = occupied_points(estimate, &occ)?;
    let (transform, icp_rms, icp_iterations, icp_inliers) =
        align(&points, ground_truth, &gt_edt, params);
    let (mut cells, outside) = resample(estimate, &ground_truth.frame, &transform, &occ, &points)?;
    drop(points);
    let e_mask: Vec<bool> = {
        let mut m = filled(h * w, false)?;
        m.par_iter_mut()
            .zip(cells.par_iter())
            .for_each(|(m, c)| *m = c & flag::ESTIMATE != 0);
        m
    };
    let e_edt = edt(&e_mask, h, w)?;
    drop(e_mask);
    let tol2 = params.tolerance * params.tolerance;
    let max = params.max_distance;
    let band = BAND_ROWS * w;
    let partials: Vec<Partial> = cells
        .par_chunks_mut(band)
        .zip(g_mask.par_chunks(band))
        .zip(gt.unknown.par_chunks(band))
        .zip(
            gt_edt
                .sqdist
                .par_chunks(band)
                .zip(e_edt.sqdist.par_chunks(band)),
        )
        .map(|(((cells, g), u), (dg, de))| {
            let mut p = Partial::default();
            for i in 0..cells.len() {
                let is_e = cells[i] & flag::ESTIMATE != 0;
                let is_g = g[i];
                let mut f = cells[i];
                if is_g {
                    f |= flag::GROUND_TRUTH;
                    p.g += 1;
                    if de[i] != u32::MAX && de[i] as f64 <= tol2 {
                        p.g_matched += 1;
                        f |= flag::GROUND_TRUTH_MATCHED;
                    }
                    let (d, t) = distance(de[i], max);
                    p.sum_ne += d;
                    p.trunc_ne += t as u64;
                } else if !u[i] {
                    f |= flag::GROUND_TRUTH_FREE;
                    p.free += 1;
                    p.covered += (cells[i] & flag::ESTIMATE_KNOWN != 0) as u64;
                }
                if is_e {
                    p.e += 1;
                    if dg[i] != u32::MAX && dg[i] as f64 <= tol2 {
                        p.e_matched += 1;
                        f |= flag::ESTIMATE_MATCHED;
                    }
                    let (d, t) = distance(dg[i], max);
                    p.sum_rev += d;
                    p.trunc_rev += t as u64;
                }
                p.inter += (is_e && is_g) as u64;
                p.union += (is_e || is_g) as u64;
                cells[i] = f;
            }
            p
        })
        .collect();
    let mut t = Partial::default();
    for p in partials {
        t.e += p.e;
        t.g += p.g;
        t.e_matched += p.e_matched;
        t.g_matched += p.g_matched;
        t.inter += p.inter;
        t.union += p.union;
        t.sum_rev += p.sum_rev;
        t.sum_ne += p.sum_ne;
        t.trunc_rev += p.trunc_rev;
        t.trunc_ne += p.trunc_ne;
        t.free += p.free;
        t.covered += p.covered;
    }
    Ok(Comparison {
        estimate_occupied: t.e,
        ground_truth_occupied: t.g,
        estimate_matched: t.e_matched,
        ground_truth_matched: t.g_matched,
        intersection: t.inter,
        union: t.union,
        sum_reverse: t.sum_rev,
        sum_ne: t.sum_ne,
        truncated_reverse: t.trunc_rev,
        truncated_ne: t.trunc_ne,
        ground_truth_free: t.free,
        covered: t.covered,
        outside,
        transform,
        icp_rms,
        icp_iterations,
        icp_inliers,
        cells: want_cells.then_some(cells),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `h x w` map, free everywhere, with walls where `wall(r, c)`; unknown outside
    /// `known(r, c)`.
    fn map(
        h: usize,
        w: usize,
        wall: impl Fn(usize, usize) -> bool,
        known: impl Fn(usize, usize) -> bool,
    ) -> (Vec<u8>, Vec<bool>) {
        let mut v = vec![254u8; h * w];
        let mut u = vec![false; h * w];
        for r in 0..h {
            for c in 0..w {
                if wall(r, c) {
                    v[r * w + c] = 0;
                }
                u[r * w + c] = !known(r, c);
            }
        }
        (v, u)
    }

    fn frame(h: usize, w: usize, res: f64, origin: Se2) -> Frame {
        Frame {
            resolution: res,
            height: h,
            width: w,
            origin,
        }
    }

    /// Walls of a building: the outline and a few inner walls with doors, plus a pillar.
    fn building(r: usize, c: usize) -> bool {
        let outer = r == 10 || r == 110 || c == 10 || c == 150;
        let inner = (c == 70 && !(40..50).contains(&r)) || (r == 60 && c < 70 && c > 30);
        let pillar = (85..90).contains(&r) && (110..115).contains(&c);
        ((10..=110).contains(&r) && (10..=150).contains(&c)) && (outer || inner || pillar)
    }

    #[test]
    fn identical_maps_match_perfectly() {
        let (h, w) = (120, 160);
        let (v, u) = map(h, w, building, |_, _| true);
        let g = Grid::new(&v, &u, h, w).unwrap();
        let f = frame(h, w, 0.05, Se2::IDENTITY);
        let p = Placed { grid: g, frame: f };
        for align in [Align::Origin, Align::Icp] {
            let params = CompareParams {
                align,
                ..Default::default()
            };
            let c = compare(&p, &p, &params, true).unwrap();
            assert_eq!(c.estimate_occupied, c.ground_truth_occupied);
            assert_eq!(c.intersection, c.union);
            assert_eq!(c.estimate_matched, c.estimate_occupied);
            assert_eq!(c.sum_ne, 0.0);
            assert_eq!(c.sum_reverse, 0.0);
            assert_eq!(c.transform.theta, 0.0);
            assert!(c.transform.tx.abs() < 1e-12 && c.transform.ty.abs() < 1e-12);
            assert_eq!(c.covered, c.ground_truth_free);
            assert_eq!(c.outside, 0);
        }
    }

    #[test]
    fn recovers_a_known_motion() {
        // the ground truth's frame is moved: the estimate must follow it back
        let (h, w) = (120, 160);
        let (v, u) = map(h, w, building, |_, _| true);
        let g = Grid::new(&v, &u, h, w).unwrap();
        let est = Placed {
            grid: g,
            frame: frame(h, w, 0.05, Se2::IDENTITY),
        };
        let moved = Se2 {
            theta: 3f64.to_radians(),
            tx: 0.3,
            ty: -0.2,
        };
        let gt = Placed {
            grid: g,
            frame: frame(h, w, 0.05, moved),
        };
        let c = compare(&est, &gt, &CompareParams::default(), false).unwrap();
        let t = c.transform;
        assert!((t.theta - moved.theta).abs() < 0.5f64.to_radians(), "{t:?}");
        assert!(
            (t.tx - moved.tx).abs() < 0.05 && (t.ty - moved.ty).abs() < 0.05,
            "{t:?}"
        );
        let o = compare(
            &est,
            &gt,
            &CompareParams {
                align: Align::Origin,
                ..Default::default()
            },
            false,
        )
        .unwrap();
        assert!(c.sum_reverse < o.sum_reverse / 4.0);
    }

    #[test]
    fn search_finds_a_large_rotation() {
        let (h, w) = (120, 160);
        let (v, u) = map(h, w, building, |_, _| true);
        let g = Grid::new(&v, &u, h, w).unwrap();
        let est = Placed {
            grid: g,
            frame: frame(h, w, 0.05, Se2::IDENTITY),
        };
        let moved = Se2 {
            theta: 97f64.to_radians(),
            tx: 5.0,
            ty: 1.0,
        };
        let gt = Placed {
            grid: g,
            frame: frame(h, w, 0.05, moved),
        };
        let p = CompareParams {
            align: Align::Search,
            ..Default::default()
        };
        let c = compare(&est, &gt, &p, false).unwrap();
        assert!((c.transform.theta - moved.theta).abs() < 0.5f64.to_radians());
        assert_eq!(c.estimate_matched, c.estimate_occupied);
    }

    #[test]
    fn missing_and_doubled_walls() {
        let (h, w) = (120, 160);
        let (gv, gu) = map(h, w, building, |_, _| true);
        let f = frame(h, w, 0.05, Se2::IDENTITY);
        let gt = Placed {
            grid: Grid::new(&gv, &gu, h, w).unwrap(),
            frame: f,
        };
        let p = CompareParams {
            align: Align::Origin,
            ..Default::default()
        };
        // missing: the inner wall at r == 60
        let (mv, mu) = map(h, w, |r, c| building(r, c) && r != 60, |_, _| true);
        let est = Placed {
            grid: Grid::new(&mv, &mu, h, w).unwrap(),
            frame: f,
        };
        let c = compare(&est, &gt, &p, false).unwrap();
        assert!(c.ground_truth_matched < c.ground_truth_occupied && c.sum_ne > 0.0);
        assert_eq!(c.sum_reverse, 0.0);
        assert_eq!(c.estimate_matched, c.estimate_occupied);
        // doubled: a copy of the wall at c == 150 at c == 140
        let (dv, du) = map(
            h,
            w,
            |r, c| building(r, c) || (c == 140 && (10..=110).contains(&r)),
            |_, _| true,
        );
        let est = Placed {
            grid: Grid::new(&dv, &du, h, w).unwrap(),
            frame: f,
        };
        let c = compare(&est, &gt, &p, false).unwrap();
        assert!(c.estimate_matched < c.estimate_occupied && c.sum_reverse > 0.0);
        assert_eq!(c.sum_ne, 0.0);
        // truncation bounds every distance
        let t = CompareParams {
            max_distance: Some(3.0),
            ..p
        };
        let c = compare(&est, &gt, &t, false).unwrap();
        assert!(c.truncated_reverse > 0 && c.sum_reverse <= 3.0 * c.estimate_occupied as f64);
    }

    #[test]
    fn same_result_for_any_thread_count() {
        let (h, w) = (120, 160);
        let (v, u) = map(h, w, building, |r, _| r < 90);
        let g = Grid::new(&v, &u, h, w).unwrap();
        let est = Placed {
            grid: g,
            frame: frame(h, w, 0.05, Se2::IDENTITY),
        };
        let gt = Placed {
            grid: g,
            frame: frame(
                h,
                w,
                0.04,
                Se2 {
                    theta: 0.03,
                    tx: 0.1,
                    ty: 0.2,
                },
            ),
        };
        let run = |t: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(t)
                .build()
                .unwrap()
                .install(|| compare(&est, &gt, &CompareParams::default(), true).unwrap())
        };
        assert_eq!(run(1), run(3));
    }
}
