//! A map against a ground-truth map (SPEC section 7): align the estimate (frames from the
//! map files, refined by trimmed ICP), resample it onto the ground truth's grid, and count
//! what the figures need (matches within the tolerance, sums of distances, coverage).
//! Ratios and metres are formed by the caller from these.

use crate::edt::{filled, Columns, EdtError};
use crate::grid::{Grid, BAND_ROWS};
use crate::icp::{icp, search, Target};
use crate::params::{Align, CompareParams};
use crate::se2::{floor_i64, Affine, Frame, Se2};
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
    let mut pts: Vec<(f64, f64)> = Vec::new();
    let to_world = p.frame.cell_to_world();
    for r in 0..g.height {
        for (c, (v, u)) in g.value_row(r).iter().zip(g.unknown_row(r)).enumerate() {
            if !*u && occ[*v as usize] {
                if pts.len() == pts.capacity() {
                    let more = pts.capacity().max(1024);
                    pts.try_reserve(more).map_err(|_| EdtError::Alloc {
                        bytes: (pts.capacity() + more).saturating_mul(16),
                    })?;
                }
                pts.push(to_world.apply(r as f64, c as f64));
            }
        }
    }
    Ok(pts)
}

/// The motion aligning the estimate, with the ICP's RMS, iterations and inliers.
fn align(
    points: &[(f64, f64)],
    gt: &Placed,
    g_columns: &Columns,
    g_mask: &[bool],
    g_list: &[u32],
    params: &CompareParams,
) -> Result<(Se2, f64, usize, usize), CompareError> {
    if params.align == Align::Origin {
        return Ok((Se2::IDENTITY, f64::NAN, 0, 0));
    }
    let target = Target::new(gt.frame, g_columns, g_mask, g_list)?;
    let start = match params.align {
        Align::Origin => Se2::IDENTITY,
        Align::Icp => Se2::IDENTITY,
        Align::Search => search(points, &target, params.trim),
    };
    Ok(
        match icp(points, &target, start, params.trim, params.max_iterations) {
            Some(r) => (r.transform, r.rms, r.iterations, r.inliers),
            None => (start, f64::NAN, 0, 0),
        },
    )
}

/// Affine map from a ground-truth cell `(row, col)` to the fractional cell position in the
/// estimate (floor = the estimate cell holding the ground-truth cell's centre), under the
/// estimate motion `t`.
fn gt_to_estimate(gt: &Frame, est: &Frame, t: &Se2) -> Affine {
    est.world_to_cell_affine()
        .after(&t.inverse().affine())
        .after(&gt.cell_to_world())
}

/// The aligned estimate on the ground truth's grid, as [`flag`] bits per ground-truth cell:
/// [`flag::ESTIMATE`], [`flag::ESTIMATE_KNOWN`], and [`flag::GROUND_TRUTH_FREE`]. A
/// ground-truth cell takes the state of the estimate cell holding its centre (nearest
/// neighbour); then every occupied estimate cell marks the ground-truth cell holding its own
/// centre, so that thin walls survive when the estimate's grid is finer.
struct Resampled {
    cells: Vec<u8>,
    /// The cells of E: row-major as the resampling finds them, then those only the
    /// occupied estimate cells' centres mark, in the estimate's row-major order.
    e_list: Vec<u32>,
    /// Occupied estimate cells whose centre falls outside the ground truth's grid.
    outside: u64,
    /// The ground truth's free cells, and those the estimate knows.
    free: u64,
    covered: u64,
}

/// `x` in 32.32 fixed point (saturating: positions far outside any grid stay outside).
#[inline]
fn fixed(x: f64) -> i64 {
    (x * 4294967296.0).round() as i64
}

fn resample(
    est: &Placed,
    ground_truth: &Placed,
    g_mask: &[bool],
    t: &Se2,
    occ: &[bool; 256],
    points: &[(f64, f64)],
) -> Result<Resampled, CompareError> {
    let gt = &ground_truth.frame;
    let gu = ground_truth.grid.unknown;
    let (h, w) = (gt.height, gt.width);
    let mut cells = filled(h * w, 0u8)?;
    let m = gt_to_estimate(gt, &est.frame, t);
    let (eh, ew) = (est.grid.height as i64, est.grid.width as i64);
    let eg = &est.grid;
    let band = BAND_ROWS * w;
    // per band: the cells of E found, free cells, covered free cells
    let parts: Vec<(Vec<u32>, u64, u64)> = cells
        .par_chunks_mut(band)
        .zip(g_mask.par_chunks(band).zip(gu.par_chunks(band)))
        .enumerate()
        .map(|(b, (chunk, (gm, un)))| {
            let mut list = band_list(chunk.len())?;
            let (mut free, mut covered) = (0u64, 0u64);
            for (k, row) in chunk.chunks_mut(w).enumerate() {
                let r = b * BAND_ROWS + k;
                // the estimate position of column 0 of this row, then one column step each
                // in 32.32 fixed point: the floor is a shift, and the steps add exactly
                let (er0, ec0) = m.apply(r as f64, 0.0);
                let (mut er, mut ec) = (fixed(er0), fixed(ec0));
                let (sr, sc) = (fixed(m.m[0][1]), fixed(m.m[1][1]));
                let (gm, un) = (&gm[k * w..(k + 1) * w], &un[k * w..(k + 1) * w]);
                for (c, ((cell, &g), &u)) in row.iter_mut().zip(gm).zip(un).enumerate() {
                    let (ir, ic) = (er >> 32, ec >> 32);
                    let is_free = !u && !g;
                    let mut f = (is_free as u8) * flag::GROUND_TRUTH_FREE;
                    if ir >= 0 && ic >= 0 && ir < eh && ic < ew {
                        let i = ir as usize * eg.width + ic as usize;
                        if !eg.unknown[i] {
                            let occupied = occ[eg.values[i] as usize];
                            f |= flag::ESTIMATE_KNOWN | ((occupied as u8) * flag::ESTIMATE);
                            covered += is_free as u64;
                            if occupied {
                                list.push((r * w + c) as u32);
                            }
                        }
                    }
                    free += is_free as u64;
                    *cell = f;
                    er = er.saturating_add(sr);
                    ec = ec.saturating_add(sc);
                }
            }
            Ok((list, free, covered))
        })
        .collect::<Result<_, EdtError>>()?;
    let (mut free, mut covered) = (0u64, 0u64);
    let mut lists = Vec::with_capacity(parts.len());
    for (list, f, c) in parts {
        lists.push(list);
        free += f;
        covered += c;
    }
    let mut e_list = concat(lists)?;
    // room for the cells only the estimate's points mark
    e_list
        .try_reserve(points.len())
        .map_err(|_| EdtError::Alloc {
            bytes: points.len().saturating_mul(4),
        })?;
    let mut outside = 0u64;
    let to_cell = gt.world_to_cell_affine().after(&t.affine());
    for &(x, y) in points {
        let (r, c) = to_cell.apply(x, y);
        let (r, c) = (floor_i64(r), floor_i64(c));
        if r >= 0 && c >= 0 && r < h as i64 && c < w as i64 {
            let i = r as usize * w + c as usize;
            let f = cells[i];
            if f & flag::ESTIMATE == 0 {
                e_list.push(i as u32);
                // a cell an occupied estimate cell marks is known
                let newly = f & flag::ESTIMATE_KNOWN == 0 && f & flag::GROUND_TRUTH_FREE != 0;
                covered += newly as u64;
            }
            cells[i] = f | flag::ESTIMATE | flag::ESTIMATE_KNOWN;
        } else {
            outside += 1;
        }
    }
    Ok(Resampled {
        cells,
        e_list,
        outside,
        free,
        covered,
    })
}

/// An empty cell list with room for a whole band of `cells` (so that filling it never
/// allocates again), or [`EdtError::Alloc`].
fn band_list(cells: usize) -> Result<Vec<u32>, EdtError> {
    let mut v = Vec::new();
    v.try_reserve_exact(cells).map_err(|_| EdtError::Alloc {
        bytes: cells.saturating_mul(4),
    })?;
    Ok(v)
}

/// The lists one after the other, in one buffer allocated fallibly.
fn concat(parts: Vec<Vec<u32>>) -> Result<Vec<u32>, EdtError> {
    let n = parts.iter().map(Vec::len).sum();
    let mut out = band_list(n)?;
    for p in parts {
        out.extend(p);
    }
    Ok(out)
}

/// Per-chunk partial sums of one side (E or G), summed in chunk order.
#[derive(Clone, Copy, Default)]
struct Side {
    matched: u64,
    sum: f64,
    truncated: u64,
    /// Cells that are also cells of the other map (for E: |E n G|).
    both: u64,
}

/// For every cell of `list`, its distance to the other map (queries of `other`): matches
/// within `tol2`, the sum of distances (truncated at `max`), how many cells `also` holds
/// for, and (when `want`) the matched flag of every cell.
fn side(
    list: &[u32],
    other: &Columns,
    tol2: f64,
    max: Option<f64>,
    also: impl Fn(usize) -> bool + Sync,
    want: bool,
) -> (Side, Vec<bool>) {
    const CHUNK: usize = 4096;
    let w = other.width;
    let parts: Vec<(Side, Vec<bool>)> = list
        .par_chunks(CHUNK)
        .map(|chunk| {
            let mut scratch = other.scratch();
            let mut s = Side::default();
            let mut matched = Vec::with_capacity(if want { chunk.len() } else { 0 });
            for &i in chunk {
                let i = i as usize;
                let sq = other
                    .query(i / w, i % w, &mut scratch)
                    .map_or(u32::MAX, |(_, d)| d);
                let ok = sq != u32::MAX && sq as f64 <= tol2;
                s.matched += ok as u64;
                let (d, t) = distance(sq, max);
                s.sum += d;
                s.truncated += t as u64;
                s.both += also(i) as u64;
                if want {
                    matched.push(ok);
                }
            }
            (s, matched)
        })
        .collect();
    let mut total = Side::default();
    let mut matched = Vec::new();
    for (s, m) in parts {
        total.matched += s.matched;
        total.sum += s.sum;
        total.truncated += s.truncated;
        total.both += s.both;
        matched.extend(m);
    }
    (total, matched)
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
    let band = BAND_ROWS * w;
    let g_parts: Vec<Vec<u32>> = g_mask
        .par_chunks_mut(band)
        .zip(gt.values.par_chunks(band))
        .zip(gt.unknown.par_chunks(band))
        .enumerate()
        .map(|(b, ((m, v), u))| {
            let mut list = band_list(m.len())?;
            for (i, ((m, v), u)) in m.iter_mut().zip(v).zip(u).enumerate() {
                *m = !*u && occ[*v as usize];
                if *m {
                    list.push((b * band + i) as u32);
                }
            }
            Ok(list)
        })
        .collect::<Result<_, EdtError>>()?;
    let g_list = concat(g_parts)?;
    // nearest-cell queries of G (ICP correspondences, d(e, G))
    let g_columns = Columns::new(|i| g_mask[i], h, w)?;
    let points = occupied_points(estimate, &occ)?;
    let (transform, icp_rms, icp_iterations, icp_inliers) =
        align(&points, ground_truth, &g_columns, &g_mask, &g_list, params)?;
    let res = resample(estimate, ground_truth, &g_mask, &transform, &occ, &points)?;
    drop(points);
    let mut cells = res.cells;
    let e_list = res.e_list;
    let e_columns = Columns::new(|i| cells[i] & flag::ESTIMATE != 0, h, w)?;
    let tol2 = params.tolerance * params.tolerance;
    let max = params.max_distance;
    let (gs, g_matched) = side(&g_list, &e_columns, tol2, max, |_| false, want_cells);
    let (es, e_matched) = side(&e_list, &g_columns, tol2, max, |i| g_mask[i], want_cells);
    if want_cells {
        for (&i, &m) in g_list.iter().zip(&g_matched) {
            cells[i as usize] |= flag::GROUND_TRUTH | ((m as u8) * flag::GROUND_TRUTH_MATCHED);
        }
        for (&i, &m) in e_list.iter().zip(&e_matched) {
            cells[i as usize] |= (m as u8) * flag::ESTIMATE_MATCHED;
        }
    }
    let (e, g) = (e_list.len() as u64, g_list.len() as u64);
    Ok(Comparison {
        estimate_occupied: e,
        ground_truth_occupied: g,
        estimate_matched: es.matched,
        ground_truth_matched: gs.matched,
        intersection: es.both,
        union: e + g - es.both,
        sum_reverse: es.sum,
        sum_ne: gs.sum,
        truncated_reverse: es.truncated,
        truncated_ne: gs.truncated,
        ground_truth_free: res.free,
        covered: res.covered,
        outside: res.outside,
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
            assert!(c.transform.theta.abs() < 1e-12);
            assert!(c.transform.tx.abs() < 1e-12 && c.transform.ty.abs() < 1e-12);
            assert_eq!(c.covered, c.ground_truth_free);
            assert_eq!(c.outside, 0);
        }
    }

    /// The building compared with itself, its ground-truth copy's frame moved by `moved`.
    fn compare_moved(moved: Se2, params: &CompareParams) -> Comparison {
        let (h, w) = (120, 160);
        let (v, u) = map(h, w, building, |_, _| true);
        let g = Grid::new(&v, &u, h, w).unwrap();
        let est = Placed {
            grid: g,
            frame: frame(h, w, 0.05, Se2::IDENTITY),
        };
        let gt = Placed {
            grid: g,
            frame: frame(h, w, 0.05, moved),
        };
        compare(&est, &gt, params, false).unwrap()
    }

    #[test]
    fn recovers_a_known_motion() {
        // the ground truth's frame is moved: the estimate must follow it back
        let moved = Se2 {
            theta: 3f64.to_radians(),
            tx: 0.3,
            ty: -0.2,
        };
        let c = compare_moved(moved, &CompareParams::default());
        let t = c.transform;
        assert!((t.theta - moved.theta).abs() < 0.5f64.to_radians(), "{t:?}");
        assert!(
            (t.tx - moved.tx).abs() < 0.05 && (t.ty - moved.ty).abs() < 0.05,
            "{t:?}"
        );
        let o = compare_moved(
            moved,
            &CompareParams {
                align: Align::Origin,
                ..Default::default()
            },
        );
        assert!(c.sum_reverse < o.sum_reverse / 4.0);
    }

    #[test]
    fn search_finds_a_large_rotation() {
        let moved = Se2 {
            theta: 97f64.to_radians(),
            tx: 5.0,
            ty: 1.0,
        };
        let p = CompareParams {
            align: Align::Search,
            ..Default::default()
        };
        let c = compare_moved(moved, &p);
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
