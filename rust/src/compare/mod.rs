//! A map against a ground-truth map (SPEC section 7): align the estimate (frames from the
//! map files, refined by trimmed ICP), resample it onto the ground truth's grid, and count
//! what the figures need (matches within the tolerance, sums of distances, coverage).
//! Ratios and metres are formed by the caller from these.
//!
//! Parts: `scan` (one pass over a map, SIMD where the processor has it: its occupied cells
//! and known cells per block), `resample` (the aligned estimate on the ground truth's grid),
//! `distances` (matches and sums of distances between the two), [`flag`] (the per-cell
//! bits).

use crate::edt::{filled, EdtError, NearestCell, Sparse};
use crate::error::Error;
use crate::icp::{icp, Occupied, Target};
use crate::params::{Align, CompareParams};
use crate::register::{register, RegisterParams};
use crate::se2::{Placed, Se2};
use distances::{plan, side, Other};
pub use resample::CellBox;
use resample::{resample, resample_box, resample_sparse, Sampled};
use scan::{scan, RowCol};

mod distances;
pub mod flag;
mod resample;
mod scan;
#[cfg(test)]
mod tests;

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

fn check(p: &Placed, what: &str) -> Result<(), Error> {
    let f = &p.frame;
    let ok = f.resolution.is_finite()
        && f.resolution > 0.0
        && f.origin.theta.is_finite()
        && f.origin.tx.is_finite()
        && f.origin.ty.is_finite();
    if !ok {
        return Err(Error::Invalid(format!(
            "{what}: resolution must be positive and origin finite"
        )));
    }
    if f.height != p.grid.height || f.width != p.grid.width {
        return Err(Error::Invalid(format!(
            "{what}: frame size differs from the grid's"
        )));
    }
    Ok(())
}

fn check_params(p: &CompareParams) -> Result<(), Error> {
    let ok = p.tolerance.is_finite()
        && p.tolerance >= 0.0
        && p.occupied_threshold.is_finite()
        && (0.0..1.0).contains(&p.occupied_threshold)
        && p.max_distance.is_none_or(|m| m.is_finite() && m > 0.0)
        && (0.0..1.0).contains(&p.trim);
    if ok {
        Ok(())
    } else {
        Err(Error::Invalid(format!(
            "comparison parameters out of range: {p:?}"
        )))
    }
}

/// The cells of `b` of a row-major grid of `w` columns.
fn crop(cells: &[u8], w: usize, b: CellBox) -> Result<Vec<u8>, Error> {
    let mut out: Vec<u8> = Vec::new();
    out.try_reserve_exact(b.height() * b.width())
        .map_err(|_| EdtError::Alloc {
            bytes: b.height() * b.width(),
        })?;
    for r in b.r0..b.r1 {
        out.extend_from_slice(&cells[r * w + b.c0..r * w + b.c1]);
    }
    Ok(out)
}

/// World centres of the cells `cells` (row-major indices) of `p`.
fn occupied_points(p: &Placed, cells: &[u32]) -> Result<Vec<(f64, f64)>, Error> {
    let w = p.grid.width;
    let mut pts: Vec<(f64, f64)> = Vec::new();
    pts.try_reserve_exact(cells.len())
        .map_err(|_| EdtError::Alloc {
            bytes: cells.len().saturating_mul(16),
        })?;
    let to_world = p.frame.cell_to_world();
    let mut at = RowCol::new(w);
    pts.extend(cells.iter().map(|&i| {
        let (r, c) = at.get(i as usize);
        to_world.apply(r as f64, c as f64)
    }));
    Ok(pts)
}

/// The motion aligning the estimate, with the ICP's RMS, iterations and inliers.
/// `Align::Search` starts the ICP from the global registration of the estimate onto the
/// ground truth (SPEC section 7a; its transform even when it refuses, the identity when it
/// found no candidate).
fn align(
    points: &[(f64, f64)],
    est: &Placed,
    gt: &Placed,
    g_columns: &dyn NearestCell,
    g_bits: &Sparse,
    g_list: &[u32],
    params: &CompareParams,
) -> Result<(Se2, f64, usize, usize), Error> {
    if params.align == Align::Origin {
        return Ok((Se2::IDENTITY, f64::NAN, 0, 0));
    }
    let target = Target::with(gt.frame, g_columns, Occupied::Bits(g_bits), g_list)?;
    let start = match params.align {
        Align::Origin => Se2::IDENTITY,
        Align::Icp => Se2::IDENTITY,
        Align::Search => {
            let p = RegisterParams {
                occupied_threshold: params.occupied_threshold,
                trim: params.trim,
                ..RegisterParams::default()
            };
            register(est, gt, &p)?.transform
        }
    };
    Ok(
        match icp(points, &target, start, params.trim, params.max_iterations) {
            Some(r) => (r.transform, r.rms, r.iterations, r.inliers),
            None => (start, f64::NAN, 0, 0),
        },
    )
}

/// Compare an estimate with a ground truth (SPEC section 7). `want_cells` keeps the per-cell
/// [`flag`] bits (for overlays).
pub fn compare(
    estimate: &Placed,
    ground_truth: &Placed,
    params: &CompareParams,
    want_cells: bool,
) -> Result<Comparison, Error> {
    let all = CellBox {
        r0: 0,
        r1: ground_truth.grid.height,
        c0: 0,
        c1: ground_truth.grid.width,
    };
    compare_within(estimate, ground_truth, params, want_cells.then_some(all))
}

/// [`compare`], keeping the per-cell [`flag`] bits of the cells of `cells` only (clipped to
/// the ground truth's grid; row-major in the box): the same counts, and the flags of the
/// whole grid's cut to the box, without resampling the estimate cell by cell outside it.
pub fn compare_within(
    estimate: &Placed,
    ground_truth: &Placed,
    params: &CompareParams,
    cells: Option<CellBox>,
) -> Result<Comparison, Error> {
    let want_cells = cells.is_some();
    check(estimate, "estimate")?;
    check(ground_truth, "ground truth")?;
    check_params(params)?;
    let occ = occupied_table(params.occupied_threshold);
    let gt = &ground_truth.grid;
    let (h, w) = (gt.height, gt.width);
    // G (and how many cells of each block of the ground truth are known), the estimate's
    // occupied cells
    let g_scan = scan(gt, &occ)?;
    let e_scan = scan(&estimate.grid, &occ)?;
    // nearest-cell queries of G (ICP correspondences, d(e, G))
    let g_near = Sparse::new(&g_scan.cells, h, w)?;
    let g_list = &g_scan.cells;
    let points = occupied_points(estimate, &e_scan.cells)?;
    // the ICP asks the nearest cell of G many times: its column pass pays off there
    let g_columns = if params.align != Align::Origin {
        Some(g_near.columns()?)
    } else {
        None
    };
    let (transform, icp_rms, icp_iterations, icp_inliers) = match &g_columns {
        Some(cols) => align(
            &points,
            estimate,
            ground_truth,
            cols,
            &g_near,
            g_list,
            params,
        )?,
        None => (Se2::IDENTITY, f64::NAN, 0, 0),
    };
    let (h0, w0) = (ground_truth.grid.height, ground_truth.grid.width);
    let cut = cells.map(|b| b.clip(h0, w0));
    let whole = CellBox {
        r0: 0,
        r1: h0,
        c0: 0,
        c1: w0,
    };
    let sparse = if cut == Some(whole) {
        None
    } else {
        resample_sparse(
            estimate,
            ground_truth,
            &g_scan,
            &g_near,
            &e_scan,
            &transform,
            &points,
        )?
    };
    // the flags and the box they are of (the whole grid after the literal resampling)
    let (mut cells, at, res) = match sparse {
        Some(r) => match cut {
            Some(b) => (
                resample_box(estimate, ground_truth, b, g_list, &transform, &occ)?,
                b,
                r,
            ),
            None => (Vec::new(), whole, r),
        },
        None => {
            // the literal resampling: with the cells, or when the sparse one cannot place
            // the frames in its fixed point (frames far apart); it reads G as a mask
            let mut g_mask = filled(h * w, false)?;
            for &i in g_list {
                g_mask[i as usize] = true;
            }
            let r = resample(estimate, ground_truth, &g_mask, &transform, &occ, &points)?;
            (
                r.cells,
                whole,
                Sampled {
                    e_list: r.e_list,
                    outside: r.outside,
                    free: r.free,
                    covered: r.covered,
                },
            )
        }
    };
    drop(points);
    let e_list = res.e_list;
    let e_near = Sparse::new(&e_list, h, w)?;
    let e_columns = plan(&e_near, g_list)?;
    let g_far = match g_columns {
        Some(_) => None,
        None => plan(&g_near, &e_list)?,
    };
    let tol2 = params.tolerance * params.tolerance;
    let max = params.max_distance;
    let e_other = match &e_columns {
        Some(c) => Other::Columns(c),
        None => Other::Sparse(&e_near),
    };
    let (gs, g_matched) = side(g_list, e_other, tol2, max, |_, _| false, want_cells);
    let g_other = match (&g_columns, &g_far) {
        (Some(c), _) | (None, Some(c)) => Other::Columns(c),
        (None, None) => Other::Sparse(&g_near),
    };
    let (es, e_matched) = side(
        &e_list,
        g_other,
        tol2,
        max,
        |r, c| g_near.get(r, c),
        want_cells,
    );
    if want_cells {
        if at != whole {
            // the cells only the estimate's points mark (resample_box left them out)
            for &i in &e_list {
                if let Some(k) = at.index(i as usize, w) {
                    cells[k] |= flag::ESTIMATE | flag::ESTIMATE_KNOWN;
                }
            }
        }
        for (&i, &m) in g_list.iter().zip(&g_matched) {
            if let Some(k) = at.index(i as usize, w) {
                cells[k] |= flag::GROUND_TRUTH | ((m as u8) * flag::GROUND_TRUTH_MATCHED);
            }
        }
        for (&i, &m) in e_list.iter().zip(&e_matched) {
            if let Some(k) = at.index(i as usize, w) {
                cells[k] |= (m as u8) * flag::ESTIMATE_MATCHED;
            }
        }
        if let Some(b) = cut.filter(|&b| b != at) {
            // the literal resampling (frames far apart): its flags cut to the box
            cells = crop(&cells, w, b)?;
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
